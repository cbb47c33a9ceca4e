//! PERM (`render --mode dvr --cache perm --qc N [--qc-grad M]`): Lim and
//! Shin's precomputed density and gradient map. Before rendering, the
//! density and the analytic gradient (the emitted `<f>_eval_grad`) are
//! computed on the device at N^3 (density) and M^3 (gradient, the paper's
//! unequal quantization) positions in every candidate cell; the ray caster
//! of [`crate::render::dvr`] then reads the nearest position instead of evaluating
//! the spline (templates/perm.wgsl.j2 for the lookup and the formats,
//! templates/perm_build.wgsl.j2 for the preprocessing).
//!
//! Cells are the unit cubes of the empty-space-skipping grid. A cell is
//! *visible* when the transfer function is not transparent over its
//! [min, max] (the emitted min/max kernel with a block edge of 1, judged by
//! [`crate::render::dvr::transfer::Tf1d::transparent`] as the skipping is). With pre-integration a segment
//! integrates the ramp between its two end values, so a segment from a
//! visible cell into a transparent neighbour needs that neighbour's true
//! value: the candidates are the visible cells dilated by ceil(step) cells
//! (Chebyshev), which holds every end of every segment touching a visible
//! cell; without pre-integration only the back value matters and the
//! candidates are the visible cells. Any other cell keeps one substitute
//! value in its index-volume entry (the middle of its [min, max], which the
//! transfer function maps to zero), so segments between non-candidates
//! integrate to zero, as they do exactly.
//!
//! The index volume has one 16-bit entry per cell and a summed-area table
//! (prefix counts) per row of x rather than per z-slice as in the paper: a
//! row has fewer than 32768 cells, so the entry's 15 bits always suffice.
//! Memory follows the paper's equations 3 and 6 with b_iv = 2, b_db = 2,
//! b_gb = 1, b_sb = 1, plus the table's 4 bytes per row ([`formula`]);
//! [`PermCache::memory`] reports the allocated buffers' sizes.
//!
//! Opaque-boundary peeling (the paper's section 5, `--peel`) drops the
//! candidate cells that no ray from outside the volume reaches before early
//! ray termination: cells enclosed by enough opaque or translucent matter
//! (the paper's properties 1 and 2) that every ray accumulates the
//! termination opacity first. [`peel`] proves it per cell with a lower bound
//! on the optical depth, so the image is the unpeeled cache's, exactly, for
//! every view from outside the volume (the renderers' orbit cameras); the
//! cache stays view-independent.

mod build;
mod index;
mod memory;
mod peel;
mod render;
mod renderer;
mod texture;

pub use build::{PermCache, PermError};
pub use index::{build_index, select_cells, Index};
pub use memory::{formula, Counts, Memory, Quant};
pub use peel::peel;
pub use render::render;
pub use renderer::PermRenderer;
pub use texture::texel_extent;

/// Bytes of one index-volume entry (b_iv).
pub const B_IV: u64 = 2;
/// Bytes of one summed-area-table entry (per row of x).
pub const B_SAT: u64 = 4;
/// Bytes of one density (b_db): 16-bit fixed point over the TF range.
pub const B_DB: u64 = 2;
/// Bytes of one gradient component's magnitude (b_gb).
pub const B_GB: u64 = 1;
/// Bytes of one gradient's sign field (b_sb).
pub const B_SB: u64 = 1;
/// The largest cache (bytes) `--qc` may ask for: the size one storage
/// buffer may safely have and the range of the shader's u32 indices.
pub const MAX_BYTES: u64 = 1 << 31;
/// Cells per row the 15-bit in-row index can address.
pub const MAX_ROW: usize = 1 << 15;
/// The paper's density quantization (`--qc` default).
pub const DEFAULT_QC: u32 = 5;
