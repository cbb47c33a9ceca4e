//! The last stage: what a user calls. The `build.rs` [`builder::Builder`],
//! deterministic atomic file output ([`output`]) and the JSON/Markdown
//! reports ([`report`]).

pub mod builder;
pub mod output;
pub mod report;
