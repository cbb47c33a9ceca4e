//! Progress bars (indicatif) for long work: hidden when stderr is not a
//! terminal, so logs and CI output stay clean.

use boxforge::derive::Derivation;
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use std::io::IsTerminal;

/// Derivations below this many polynomials finish in well under a second:
/// no bar for them.
pub const BAR_FROM_POLYNOMIALS: usize = 2000;

/// A bar of `len` steps labelled `what`; hidden off a terminal.
pub fn bar(len: u64, what: &str) -> ProgressBar {
    let bar = ProgressBar::with_draw_target(Some(len), draw_target());
    bar.set_style(
        ProgressStyle::with_template("{msg} [{bar:30}] {pos}/{len} ({elapsed}, {eta} left)")
            .expect("a valid template")
            .progress_chars("=> "),
    );
    bar.set_message(what.to_string());
    bar
}

/// The bar for deriving `d`'s reference pieces (hidden for small ones).
pub fn derivation_bar(d: &Derivation) -> ProgressBar {
    let polynomials = d.polynomials();
    if polynomials < BAR_FROM_POLYNOMIALS {
        return ProgressBar::hidden();
    }
    bar(d.references.len() as u64, &format!("deriving {} ({polynomials} polynomials), reference pieces", d.filter.name))
}

fn draw_target() -> ProgressDrawTarget {
    if std::io::stderr().is_terminal() {
        ProgressDrawTarget::stderr()
    } else {
        ProgressDrawTarget::hidden()
    }
}

/// Progress through named steps of unknown count (bench, demo): a spinner
/// with the current step on a terminal; elsewhere one timestamped line per
/// step, so logs keep a record of where the time went.
pub struct Steps {
    spinner: Option<ProgressBar>,
    started: std::time::Instant,
}

impl Steps {
    pub fn new() -> Steps {
        let spinner = std::io::stderr().is_terminal().then(|| {
            let s = ProgressBar::new_spinner();
            s.set_style(ProgressStyle::with_template("{spinner} [{elapsed:>4}] {msg}").expect("a valid template"));
            s.enable_steady_tick(std::time::Duration::from_millis(120));
            s
        });
        Steps { spinner, started: std::time::Instant::now() }
    }

    /// Starts a step.
    pub fn step(&self, what: &str) {
        match &self.spinner {
            Some(s) => s.set_message(what.to_string()),
            None => eprintln!("[{:>6.1} s] {what}", self.started.elapsed().as_secs_f64()),
        }
    }

    /// A line that stays (a result), printed above the spinner.
    pub fn println(&self, line: &str) {
        match &self.spinner {
            Some(s) => s.println(line),
            None => eprintln!("{line}"),
        }
    }

    pub fn finish(&self) {
        if let Some(s) = &self.spinner {
            s.finish_and_clear();
        }
    }
}

impl Default for Steps {
    fn default() -> Steps {
        Steps::new()
    }
}
