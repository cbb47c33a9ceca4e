//! `boxforge list`: the built-in catalog and the hand-written schemes.

use crate::common::Failure;
use boxforge::spec;

pub fn run() -> Result<(), Failure> {
    for name in spec::catalog::names() {
        let f = spec::catalog::get(name)?;
        outln!("{:<16} {:<9} {}", f.name, f.lattice.name, f.description);
    }
    for s in boxforge_runtime::render::schemes::ALL {
        outln!("{:<16} {:<9} {}", s.name(), "bcc", s.description());
    }
    Ok(())
}
