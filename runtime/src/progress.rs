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
