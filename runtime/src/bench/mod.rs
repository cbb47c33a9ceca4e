//! `boxforge bench`: every claim gets a number, measured in one run. Every
//! comparison is timed in interleaved rounds (each contender once per round,
//! rotating which goes first), the ratio is taken per round, and the report
//! gives the median ratio with its min..max over rounds (a range spanning 1.0
//! is a tie).
//!
//! The main report lives in this folder's private files, re-exported here:
//! options.rs (what to measure), run.rs (measuring it), job.rs (a compiled
//! throughput kernel and interleaved timing), compare.rs (generated vs
//! hand-written; glsl_rivals.rs, its GLSL row), quality.rs (accuracy and convergence), rows.rs (the
//! report), markdown.rs (docs/BENCHMARKS.md) and error.rs. The other modes
//! of `boxforge bench` have their own public modules.

pub mod curvature;
pub mod derive;
pub mod dvr;
pub mod four;
pub mod glsl_rivals;
pub mod hessian;
pub mod hit;
pub mod levels;
pub mod literature;
pub mod perm;
pub mod volumes;

pub mod stats;

mod compare;
mod error;
mod job;
pub mod markdown;
mod options;
mod quality;
mod rows;
mod run;

pub use compare::{compare_reference, loads_only, REFERENCE_TOLERANCE};
pub use error::BenchError;
pub use job::{can_filter_f32, program, timed_rounds, Job};
pub use markdown::{markdown, references_section, splice_references};
pub use options::{check_inputs, BenchOptions, External};
pub use quality::{eval_rates, smooth_convergence};
pub use rows::{BenchReport, BenchRow, ConvergenceRow, GradientRow, QualityRow, ReferenceRow};
pub use run::{machine_description, run, run_with};
