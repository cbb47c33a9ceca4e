//! Out of core: isosurfaces and volume renderings of volumes larger than
//! the device's memory budget (and than one texture). The samples live in
//! bricks of the bricked layout ([`boxforge::emit::bricks`]); a pool of as
//! many brick slots as the budget holds is filled on demand (`pool`, the
//! core both renderers share). A frame renders in passes: the ray caster
//! walks each ray as the in-core caster does until it needs a brick the
//! pool lacks, records the brick and where to resume, and stops; the host
//! uploads the requested bricks (evicting the least recently requested)
//! and dispatches again until every ray is done. The image equals the
//! in-core one: the same evaluations at the same points.
//!
//! - [`PagedIsoRenderer`]: the fixed-step isosurface walk; where a block is
//!   known empty its bounds' midpoint stands in for the value (same sign),
//!   so bricks holding only empty blocks are never uploaded.
//! - [`PagedDvrRenderer`]: emission-absorption segments with the
//!   transfer-function-aware skipping of the in-core caster, so bricks that
//!   only skipped segments cross are never uploaded.
//!
//! The block bounds are computed brick row by brick row before the first
//! frame ([`bounds`]), so nothing needs the whole volume on the device or
//! in host memory when the source is a mapped file.

pub mod bounds;
pub mod cache;
mod dvr;
mod iso;
mod pool;

pub use dvr::PagedDvrRenderer;
pub use iso::PagedIsoRenderer;

use crate::render::RenderError;
use crate::volume::{BrickShape, SampleFormat};

/// What an out-of-core isosurface needs besides the camera.
#[derive(Clone, Debug)]
pub struct PagedOptions {
    /// The iso-value (the isosurface renderer's; DVR takes a transfer function).
    pub iso: f32,
    /// Ray step in cells (the isosurface renderer's; DVR's is its look's).
    pub step: f32,
    /// Edge of the min/max blocks in unit cubes (divides the brick edge).
    pub block: i32,
    /// Brick edge in lattice texels (a multiple of the block edge and of the
    /// lattice's period); the halo is the filter's.
    pub brick: usize,
    /// Stored sample format.
    pub format: SampleFormat,
    /// Device memory for everything this renderer allocates, in bytes.
    pub budget: u64,
    /// The largest image (pixels) the budget reserves room for.
    pub max_pixels: u64,
    /// Cap on the pool texture's edge (None: the adapter's limit); tests
    /// force small pools with it.
    pub max_pool_edge: Option<usize>,
    /// A folder where the block bounds of a source with an
    /// [`identity`](crate::volume::BrickSource::identity) are kept (`bounds-<key>.bin`), so a
    /// second render of the same file, filter and storage skips the pass
    /// over the whole volume (minutes at 1024^3); None: always computed.
    pub bounds_cache: Option<std::path::PathBuf>,
}

impl Default for PagedOptions {
    fn default() -> Self {
        PagedOptions {
            iso: 0.5,
            step: 0.25,
            block: 4,
            brick: BrickShape::DEFAULT_EDGE,
            format: SampleFormat::F32,
            budget: 1 << 30,
            max_pixels: 512 * 512,
            bounds_cache: None,
            max_pool_edge: None,
        }
    }
}

/// What rendering one frame out of core took.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[cfg_attr(feature = "files", derive(serde::Serialize))]
pub struct PagedStats {
    /// Dispatches of the ray caster (1: everything was resident).
    pub passes: usize,
    /// Bricks uploaded during the frame.
    pub uploads: usize,
    /// Bricks evicted during the frame.
    pub evictions: usize,
    /// Slots in the pool.
    pub slots: usize,
    /// Bricks of the volume.
    pub bricks: usize,
    /// Bricks with a non-empty block for this iso-value (the most a frame can need).
    pub occupied_bricks: usize,
    /// Device bytes this renderer allocated (pool, page table, bounds, image buffers).
    pub device_bytes: u64,
    /// Milliseconds of the frame (all passes, uploads included).
    pub ms: f64,
}

/// The most passes one frame may take before the pool is declared too small.
pub const MAX_PASSES: usize = 4096;

/// The pixels of a `width` x `height` frame, refused when there are none or
/// more than the renderer's budget reserved.
fn check_pixels(width: u32, height: u32, max_pixels: u64) -> Result<u64, RenderError> {
    let pixels = width as u64 * height as u64;
    if pixels == 0 {
        return Err(RenderError::EmptyTarget);
    }
    if pixels > max_pixels {
        return Err(RenderError::FrameTooLarge { width, height, max_pixels });
    }
    Ok(pixels)
}

/// Bricks holding at least one block whose bounds contain the iso-value
/// (`per` blocks per brick edge).
fn occupied(empty: &[u32], grid: [i32; 3], bricks: [usize; 3], per: usize) -> usize {
    let mut occ = vec![false; bricks.iter().product()];
    let g = grid.map(|n| n as usize);
    for z in 0..g[2] {
        for y in 0..g[1] {
            for x in 0..g[0] {
                if empty[x + g[0] * (y + g[1] * z)] == 0 {
                    occ[x / per + bricks[0] * (y / per + bricks[1] * (z / per))] = true;
                }
            }
        }
    }
    occ.iter().filter(|&&o| o).count()
}

/// Bytes as KiB, MiB or GiB (the messages and reports of the budget).
pub use crate::memory::human;
