//! Progress bars (indicatif, with the `progress` feature) for long work:
//! hidden when stderr is not a terminal, so logs and CI output stay clean.
//! Without the feature the bars are silent and steps are plain lines.

use boxforge::derive::Derivation;
#[cfg(feature = "progress")]
pub use indicatif::ProgressBar;
#[cfg(feature = "progress")]
use indicatif::{ProgressDrawTarget, ProgressStyle};
#[cfg(feature = "progress")]
use std::io::IsTerminal;

/// A silent progress bar (a build without the `progress` feature).
#[cfg(not(feature = "progress"))]
#[derive(Clone, Debug, Default)]
pub struct ProgressBar;

#[cfg(not(feature = "progress"))]
impl ProgressBar {
    pub fn hidden() -> ProgressBar {
        ProgressBar
    }
    pub fn inc(&self, _delta: u64) {}
    pub fn set_position(&self, _pos: u64) {}
    pub fn println(&self, line: &str) {
        eprintln!("{line}");
    }
    pub fn finish_and_clear(&self) {}
}

/// A silent bar (a build without the `progress` feature).
#[cfg(not(feature = "progress"))]
pub fn bar(_len: u64, _what: &str) -> ProgressBar {
    ProgressBar
}

/// Derivations below this many polynomials finish in well under a second:
/// no bar for them.
pub const BAR_FROM_POLYNOMIALS: usize = 2000;

/// A bar of `len` steps labelled `what`; hidden off a terminal.
#[cfg(feature = "progress")]
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

#[cfg(feature = "progress")]
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
        #[cfg(feature = "progress")]
        let spinner = std::io::stderr().is_terminal().then(|| {
            let s = ProgressBar::new_spinner();
            s.set_style(ProgressStyle::with_template("{spinner} [{elapsed:>4}] {msg}").expect("a valid template"));
            s.enable_steady_tick(std::time::Duration::from_millis(120));
            s
        });
        #[cfg(not(feature = "progress"))]
        let spinner: Option<ProgressBar> = None;
        Steps { spinner, started: std::time::Instant::now() }
    }

    /// Starts a step.
    pub fn step(&self, what: &str) {
        match &self.spinner {
            #[cfg(feature = "progress")]
            Some(s) => s.set_message(what.to_string()),
            #[cfg(not(feature = "progress"))]
            Some(_) => {}
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
