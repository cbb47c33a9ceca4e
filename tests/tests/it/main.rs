//! Cross-crate integration tests in one binary.

mod d4;
mod error_texts;
mod file_sizes;
mod fuzz_corpus;
mod import_cycles;
mod literature;
mod mattausch;
mod oracle_agreement;
mod partition_and_reproduction;
mod random_directions;
mod random_specs;
mod shaders_out_fresh;
mod targets;
mod wgsl;
