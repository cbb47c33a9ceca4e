//! boxforge: exact box-spline derivations and branch-free WGSL generation.
//!
//! The pipeline reads like a compiler: [`spec`] (input) → [`spline`]
//! (direction-matrix facts) → [`arrangement`] (knot planes, cells) →
//! [`pieces`] (exact polynomials) → [`symmetry`] (reference pieces) →
//! [`stencil`], [`bb`] and [`prefilter`] → [`eval`] (evaluator).

pub mod arrangement;
pub mod bb;
pub mod builder;
pub mod derive;
pub mod emit;
pub mod error;
pub mod eval;
pub mod exact;
pub mod fetch_order;
pub mod lattice;
pub mod linalg;
pub mod oracle;
pub mod output;
pub mod pieces;
pub mod plan;
pub mod poly;
pub mod polytope;
pub mod prefilter;
pub mod report;
pub mod spec;
pub mod spline;
pub mod symmetry;
pub mod validate;

pub use builder::Builder;
pub use error::{Error, Result};
pub use spec::Filter;
