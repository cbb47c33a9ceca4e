//! boxforge: exact box-spline derivations and branch-free WGSL generation.
//!
//! The crate reads like a compiler, one folder per stage, plain data between
//! them (see `docs/ARCHITECTURE.md`):
//!
//! ```text
//! spec ──► derive ──► eval        (exact / f64 evaluators, de Boor oracle)
//!  TOML      facts, arrangement, pieces, symmetry, stencils, BB, prefilter
//!             └────► emit ──► validate ──► build
//!                    plan, fetch order, forms, WGSL   naga   Builder, files, reports
//! ```
//!
//! * [`spec`]: the input: spec files, lattices, caps, the built-in catalog.
//! * [`derive`](mod@derive): everything derived exactly from the direction matrix.
//! * [`eval`]: evaluation of a derived spline (exact, f64) and the independent
//!   de Boor oracle the tests compare against.
//! * [`emit`]: branch-free point location, fetch order, evaluation forms and
//!   the WGSL writer.
//! * [`validate`]: naga validation and the branch-free / table-free proof.
//! * [`back`]: the validated module translated by naga's backends into
//!   SPIR-V, GLSL, GLSL ES, HLSL and MSL, checked, and compiled where a
//!   compiler exists (`generate --target`).
//! * [`build`]: the `build.rs` [`Builder`], atomic file output and reports.
//! * [`math`]: exact rationals, linear algebra, polynomials, polytopes.

// The exact numeric code indexes several parallel arrays (coordinates,
// rows, planes) by one loop variable; iterator chains would hide that.
#![allow(clippy::needless_range_loop)]
// Every public item carries rustdoc (issue #9); `-D warnings` keeps it so.
#![warn(missing_docs)]

pub mod back;
pub mod build;
pub mod derive;
pub mod emit;
pub mod error;
pub mod eval;
pub mod math;
pub mod spec;
pub mod validate;

pub use build::builder::Builder;
pub use error::{Error, Result};
pub use spec::Filter;
