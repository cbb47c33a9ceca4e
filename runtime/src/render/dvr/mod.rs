//! Direct volume rendering (`render --mode dvr`): the emitted filter module
//! plus `templates/dvr.wgsl.j2`, a 1D transfer function ([`crate::render::dvr::transfer`])
//! with optional pre-integration, gradient shading from `<f>_eval_grad`,
//! early ray termination and empty-space skipping that knows the transfer
//! function; and a CPU reference ([`cpu_render`]) in f64 with the exact
//! evaluator that the GPU image must match.
//!
//! The model (both renderers): emission-absorption composited front to back
//! over segments of `step` cells from the ray's entry into the valid box
//! (segment k spans t0 + k step .. t0 + (k + 1) step; a partial last segment
//! is dropped). A segment's value and gradient are taken at its back end.
//! Without pre-integration its colour and opacity are the 1D table's at the
//! back value with opacity correction alpha = 1 - exp(-tau step) =
//! 1 - (1 - opacity)^(step / REF_STEP); with pre-integration they are the
//! table's entry for (front value, back value) (bilinear) and the normal
//! comes from the mean of the front and back gradients (the midpoint's to
//! second order: the back one alone shows the slabs again). Shading
//! multiplies the premultiplied colour by ambient + diffuse |n.l| and adds
//! alpha x specular |n.h|^20 (two-sided, the iso renderer's light), mixed
//! with the unshaded colour by the weight |g|^2 / (|g|^2 + g0^2), g0 = 2% of
//! the transfer function's range per cell, so flat regions (noisy normals)
//! stay unshaded. Rays stop once their opacity reaches
//! [`DvrOptions::termination`]; the rest shows the iso renderer's background.
//!
//! Skipping: the emitted `<f>_minmax_main` kernel bounds the spline on each
//! block of B^3 cubes; a block is flagged empty when the transfer function is
//! transparent over its [min, max] ([`transfer::Tf1d::transparent`]), and skipped
//! when it and its neighbours within ceil(step / B) blocks are empty
//! ([`skip_flags`]). A ray whose segment starts in a skipped block jumps over
//! every segment starting in that block (they end in empty blocks), so the
//! segment grid, and the image, are those of the unskipped ray. The flags
//! the caster reads are skip distances ([`skip_distances`], from a Chebyshev
//! distance transform of the empty blocks): a block with distance s skips
//! the whole box of blocks within s - 1 of it in one jump
//! ([`DvrOptions::skip_map`]: or one block at a time).

pub(crate) mod caster;
mod cpu;
mod params;
pub mod renderer;
mod scene;
mod skip;
pub mod transfer;

pub use cpu::{cpu_render, rms};
pub use params::{dvr_params, DvrParams};
pub use renderer::{DvrLook, DvrRenderer};
pub(crate) use scene::caster_entries;
#[cfg(feature = "references")]
pub(crate) use scene::Custom;
pub use scene::{render, DvrScene};
pub use skip::{empty_flags, skip_distances, skip_flags, widen_bounds};

use crate::render::iso::RenderOptions;
use crate::render::RenderError;
use boxforge::derive::Derivation;
use boxforge::emit::{emit, EmitOptions, Layout};

/// Ambient, diffuse and specular weights of the shading.
pub const LIGHT: [f32; 3] = [0.35, 0.65, 0.25];
/// The shading weight's gradient scale, as a fraction of the TF range per cell.
pub const G0_OF_RANGE: f32 = 0.02;
/// Background colour (the iso renderer's).
pub const BACKGROUND: [f64; 3] = [0.08, 0.08, 0.1];

/// Options of one DVR image.
#[derive(Clone, Debug)]
pub struct DvrOptions {
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
    /// View azimuth and elevation in degrees.
    pub azimuth: f32,
    /// See `azimuth`.
    pub elevation: f32,
    /// Perspective (else orthographic) projection, as the iso renderer's.
    pub perspective: bool,
    /// TF-aware empty-space skipping.
    pub skip: bool,
    /// How far a skip jumps: by the distance map, or one block at a time.
    pub skip_map: crate::render::blocks::SkipMap,
    /// Pre-integrated segments (else point samples with opacity correction).
    pub preintegrate: bool,
    /// Segment length in cells.
    pub step: f32,
    /// Block edge of the skipping grid, in unit cubes.
    pub block: i32,
    /// Early ray termination: stop at this accumulated opacity.
    pub termination: f32,
    /// Frames to time after one warm-up frame.
    pub frames: usize,
    /// Render in bands of rows with a progress bar on stderr.
    pub progress: bool,
    /// How the one-shot [`render`] stores the samples (format, bricks).
    pub volume: crate::volume::VolumeOptions,
    /// The curvature transfer function (`--tf-curvature`) with its
    /// saturation radius in cells: colour by (k1, k2) from `<f>_eval_hessian`.
    pub curvature: Option<f32>,
}

impl Default for DvrOptions {
    fn default() -> Self {
        DvrOptions {
            width: 256,
            height: 256,
            azimuth: 30.0,
            elevation: 25.0,
            perspective: false,
            skip: true,
            skip_map: Default::default(),
            preintegrate: true,
            step: 0.5,
            block: 4,
            termination: 0.99,
            frames: 3,
            progress: false,
            volume: Default::default(),
            curvature: None,
        }
    }
}

impl DvrOptions {
    /// The iso renderer's options with the same camera (for [`ray_params`]).
    pub(crate) fn camera(&self) -> RenderOptions {
        RenderOptions {
            width: self.width,
            height: self.height,
            azimuth: self.azimuth,
            elevation: self.elevation,
            perspective: self.perspective,
            step: self.step,
            block: self.block,
            skip: self.skip,
            skip_map: self.skip_map,
            ..RenderOptions::default()
        }
    }
}

/// The DVR template for filter `name`; `lookup` makes the ray caster take
/// its samples from `<f>_perm_sample`, a function the caller's module
/// supplies (a cache built on top of DVR), instead of calling
/// `<f>_eval_grad` (the only difference in the text).
pub(crate) fn dvr_template(name: &str, lookup: bool) -> String {
    dvr_template_with(name, lookup, false)
}

/// [`dvr_template`], with `host_depth` the host-depth input of
/// [`DvrRenderer`] (group 1, bindings 6 and 7; without it the text is the
/// one the web viewer, PERM and the schemes have always had).
pub(crate) fn dvr_template_with(name: &str, lookup: bool, host_depth: bool) -> String {
    dvr_template_curvature(name, lookup, host_depth, None)
}

/// Refuses the curvature transfer function where it cannot be: a filter
/// without `<f>_eval_hessian` (degree 1), a radius not finite and > 0.
pub(crate) fn check_curvature_tf(d: &Derivation, radius: f32) -> Result<(), RenderError> {
    let shade =
        crate::render::iso::Shade { mode: crate::render::iso::ShadeMode::Curvature, radius, ..Default::default() };
    crate::render::iso::check_shade(d, &shade)
}

/// [`dvr_template_with`] with the curvature transfer function of radius
/// `curvature` (cells): samples from `<f>_eval_hessian`, coloured by (k1, k2).
pub(crate) fn dvr_template_curvature(name: &str, lookup: bool, host_depth: bool, curvature: Option<f32>) -> String {
    dvr_template_full(name, lookup, host_depth, curvature, false)
}

/// The DVR template out of core (`templates/paged.wgsl.j2` included): the
/// samples from the brick pool, suspended and resumed across passes
/// ([`crate::render::paged::PagedDvrRenderer`]).
pub(crate) fn dvr_template_paged(name: &str) -> String {
    dvr_template_full(name, false, false, None, true)
}

fn dvr_template_full(name: &str, lookup: bool, host_depth: bool, curvature: Option<f32>, paged: bool) -> String {
    let text = crate::render::templates::render(
        "dvr",
        minijinja::context! { name => name, perm => lookup, host_depth => host_depth, curvature => curvature.is_some(), paged => paged },
    );
    match curvature {
        Some(r) => format!("{text}{}", crate::render::iso::curvature::curvature_tf_wgsl(name, r)),
        None => text,
    }
}

/// The emitted module with the DVR template appended.
pub fn shader_source(d: &Derivation, layout: Layout) -> Result<String, RenderError> {
    shader_source_with(d, &module_options(layout), false)
}

/// The emitter's options for a DVR module in `layout` (f32 samples).
fn module_options(layout: Layout) -> EmitOptions {
    EmitOptions { layout, command: DVR_COMMAND.into(), ..Default::default() }
}

/// The command DVR modules name in their header.
pub(crate) const DVR_COMMAND: &str = "boxforge render --mode dvr";

/// [`shader_source`], with `lookup` the ray caster sampling through
/// `<f>_perm_sample` ([`dvr_template`]), which the caller appends.
pub(crate) fn shader_source_with(d: &Derivation, module: &EmitOptions, lookup: bool) -> Result<String, RenderError> {
    Ok(format!("{}\n{}", filter_module_with(d, module)?, dvr_template(&d.filter.name, lookup)))
}

/// The emitted filter module (fetch, eval, eval_grad, min/max kernel).
#[cfg(any(test, feature = "references"))]
pub(crate) fn filter_module(d: &Derivation, layout: Layout) -> Result<String, RenderError> {
    filter_module_with(d, &module_options(layout))
}

/// [`filter_module`] with the emitter's options (a volume's
/// [`DeviceVolume::emit_options`](crate::volume::DeviceVolume::emit_options)).
pub(crate) fn filter_module_with(d: &Derivation, module: &EmitOptions) -> Result<String, RenderError> {
    let module = emit(d, module)?;
    Ok(module.source)
}
