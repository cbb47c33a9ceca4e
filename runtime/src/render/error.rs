//! The renderers' error type.

use crate::gpu::GpuError;
use crate::memory::human;

/// What can go wrong building or driving a renderer.
#[derive(Debug, thiserror::Error)]
pub enum RenderError {
    #[error(transparent)]
    Gpu(#[from] GpuError),
    /// The generator refused the renderer's module, or a filter that does
    /// not resolve or derive (its message names the reason).
    #[error(transparent)]
    Generator(#[from] boxforge::Error),
    /// The volume could not be read, stored or uploaded.
    #[error(transparent)]
    Volume(#[from] crate::volume::VolumeError),
    /// A prepared scene, cache or table used with options it was not built for.
    #[error("{0}: build it again for these options")]
    BuiltForOther(Mismatch),
    /// A PERM cache peeled for rays that stop earlier than the render's.
    #[error("this PERM cache was peeled for rays that stop at opacity {peeled}; a render with termination {asked} may reach peeled cells: build one for it")]
    PermPeeled { peeled: f32, asked: f32 },
    /// A dispatch before any frame was prepared.
    #[error("no frame was prepared: prepare a frame before dispatching it")]
    NoFrame,
    /// Curvature shading of a filter with no second derivatives.
    #[error("{mode} shading needs second derivatives, but {filter} has degree {degree} (its pieces are linear, its Hessian zero): use a filter of degree >= 2 such as bcc7 or cc_tricubic")]
    ShadeNeedsDegree { mode: &'static str, filter: String, degree: usize },
    /// A curvature radius or contour thickness that is not finite and > 0.
    #[error("curvature radius {radius} and contour thickness {thickness} must be finite and > 0")]
    ShadeControls { radius: f32, thickness: f32 },
    /// The 4D exact hit asked of a filter that is not 4D.
    #[error("the exact hit of the 4D renderer needs a 4D filter")]
    NotFourD,
    /// The curvature transfer function out of core.
    #[error("the curvature transfer function is not rendered out of core: drop the curvature or the device budget")]
    PagedCurvature,
    /// A brick edge the block grid or the lattice cannot tile.
    #[error("brick edge {brick} must be a multiple of the block edge {block} and of the lattice's period {period} (e.g. 32)")]
    BrickEdge { brick: usize, block: usize, period: usize },
    /// A device budget below the fixed tables plus eight brick slots.
    #[error("a device budget of {} is too small: the page table, block bounds and image buffers take {} and the pool needs at least 8 brick slots of {} ({slot}^3 texels of {format}); give at least {}", human(*budget), human(*fixed), human(*slot_bytes), human(*need))]
    BudgetTooSmall { budget: u64, fixed: u64, slot_bytes: u64, slot: usize, format: &'static str, need: u64 },
    /// A pool texture too small for eight slots at the device's edge limit.
    #[error("a pool texture of at most {max_edge} texels per edge holds {capacity} slots of {slot}^3: use a smaller brick edge")]
    PoolEdge { max_edge: usize, capacity: usize, slot: usize },
    /// An out-of-core frame that did not finish in the pass limit.
    #[error("the frame did not complete in {passes} passes: the pool of {slots} slots is too small for the bricks its rays need at once; raise the budget")]
    FrameIncomplete { passes: usize, slots: usize },
    /// Rays waiting for bricks that no slot of the pool can take.
    #[error("{pending} rays wait for bricks but none fits the pool of {slots} slots: raise the budget")]
    PoolStarved { pending: u64, slots: usize },
    /// An out-of-core frame larger than the renderer reserved.
    #[error("a {width}x{height} frame is larger than the {max_pixels} pixels this renderer's budget reserved (PagedOptions::max_pixels)")]
    FrameTooLarge { width: u32, height: u32, max_pixels: u64 },
    #[error("the target has no pixels: give it a width and height of at least 1")]
    EmptyTarget,
    #[error("a {width}x{height} image needs {} bytes in one storage binding, over this device's max_storage_buffer_binding_size ({limit}); render a smaller target", *width as u64 * *height as u64 * 4)]
    TargetTooLarge { width: u32, height: u32, limit: u64 },
    /// Projected tetrahedra tile only the BCC and CC lattices.
    #[error("projected tetrahedra need BCC or CC data, not the {lattice} lattice: use the ray caster")]
    PtLattice { lattice: String },
    /// Projected tetrahedra in a perspective view.
    #[error("projected tetrahedra here are orthographic (the implicit back-to-front traversal is a visibility order only for parallel projection): render a parallel view or use the ray caster")]
    PtPerspective,
    /// Projected tetrahedra's samples or visible tetrahedra past one storage binding.
    #[error("projected tetrahedra: the {what} take {bytes} bytes, over this adapter's storage-binding limit of {limit}: use a smaller volume (e.g. resampled from a downsampled file) or the ray caster")]
    PtTooLarge { what: &'static str, bytes: u64, limit: u64 },
    /// A hand-written BCC scheme given samples on another lattice.
    #[error("{scheme} reads BCC samples; the volume is on the {lattice} lattice")]
    SchemeLattice { scheme: &'static str, lattice: String },
    /// A hand-written scheme given samples in a layout its loads do not read.
    #[error("{scheme} reads the embedded layout (one 3D texture of the samples); upload the volume in that layout")]
    SchemeLayout { scheme: &'static str },
    /// A host depth texture ([`crate::render::camera::HostDepth`]) of a format the ray casters cannot read as depth.
    #[error("the host depth texture is {format:?}, which the ray casters do not read: pass a Depth32Float, Depth24Plus or Depth16Unorm texture (no stencil aspect)")]
    HostDepthFormat { format: wgpu::TextureFormat },
    /// A host depth texture the ray casters cannot bind.
    #[error(
        "the host depth texture has usage {usage:?} without TEXTURE_BINDING: create it with TEXTURE_BINDING as well"
    )]
    HostDepthUsage { usage: wgpu::TextureUsages },
    /// A host depth texture whose texels are not the target's pixels.
    #[error("the host depth texture is {}x{} with {samples} sample(s), the target {}x{}: pass a single-sample depth texture of the target's size", depth[0], depth[1], target[0], target[1])]
    HostDepthSize { depth: [u32; 2], samples: u32, target: [u32; 2] },
}

/// What a prepared scene, cache or table was built for, against what the
/// options ask (for [`RenderError::BuiltForOther`]).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum Mismatch {
    /// A scene's skipping blocks, bounded for another block edge.
    #[error("the scene's block grid was built for block edge {built}, the options ask for block edge {asked}")]
    BlockEdge { built: i32, asked: i32 },
    /// A scene's shader, built with another curvature transfer function radius.
    #[error("the scene's shader (DvrScene::with_curvature) was built for curvature transfer function {built:?}, the options ask for {asked:?}")]
    Curvature { built: Option<f32>, asked: Option<f32> },
    /// A pre-integration table for segments of another step.
    #[error("the pre-integration table was built for step {built}, the options ask for step {asked}")]
    PreintStep { built: f32, asked: f32 },
    /// A PERM cache built for another transfer function, a shorter step,
    /// or with(out) pre-integration.
    #[error("the PERM cache was built for its transfer function at step {built_step} (pre-integrated: {built_preint}), the options ask for another transfer function or step {asked_step} (pre-integrated: {asked_preint})")]
    PermTables { built_step: f32, built_preint: bool, asked_step: f32, asked_preint: bool },
}
