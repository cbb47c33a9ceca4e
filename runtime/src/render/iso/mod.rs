//! Isosurface rendering: the emitted filter module plus the ray-casting
//! template (`templates/raycast.wgsl.j2`), the BB min/max block grid from the
//! emitted min/max kernel, and a CPU reference ray caster for tests.

pub mod cpu;
pub mod curvature;
pub mod hit;
pub mod renderer;
pub(crate) mod template;

use crate::gpu::Gpu;
use crate::render::RenderError;
use crate::volume::DeviceVolume;
use crate::volume::LatticeVolume;
use boxforge::derive::Derivation;
use boxforge::emit::{emit, EmitOptions, Layout};
pub use cpu::{cpu_render, cpu_render_with_depth, hit_exact};
pub use curvature::{Shade, ShadeMode};
use glam::{DVec3, Vec3};
pub use hit::*;

#[derive(Clone, Debug)]
pub struct RenderOptions {
    pub iso: f32,
    pub width: u32,
    pub height: u32,
    /// View azimuth and elevation in degrees.
    pub azimuth: f32,
    pub elevation: f32,
    pub perspective: bool,
    /// Empty-space skipping with the min/max block grid.
    pub skip: bool,
    /// How far a skip jumps: by the distance map, or one block at a time.
    pub skip_map: crate::render::blocks::SkipMap,
    /// Ray step in cells.
    pub step: f32,
    /// Block edge in unit cubes.
    pub block: i32,
    /// Frames to time after one warm-up frame.
    pub frames: usize,
    /// Render in bands of rows and report progress on stderr (for long renders).
    pub progress: bool,
    /// How a ray finds the surface: exactly, piece by piece, or by fixed steps.
    pub hit: HitMode,
    /// How the one-shot renders store the samples (format, bricks).
    pub volume: crate::volume::VolumeOptions,
    /// How hits are coloured: Phong, or curvature from `<f>_eval_hessian`.
    pub shade: Shade,
}

/// How the ray caster finds the first iso-surface crossing along a ray.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum HitMode {
    /// Piece by piece: the ray is cut at every grid and knot plane, the
    /// spline on each segment is one polynomial of the filter's degree whose
    /// Bernstein coefficients (from degree + 1 samples) exclude the segment
    /// or lead to its first root by Bernstein subdivision. Finds thin
    /// features that fixed steps jump over.
    Exact,
    /// Fixed steps of `step` cells with a sign test, then bisection (the
    /// library default, so existing callers and bench rows keep their meaning).
    #[default]
    Step,
}

impl HitMode {
    /// `exact` or `step`.
    pub fn parse(s: &str) -> Option<HitMode> {
        match s {
            "exact" => Some(HitMode::Exact),
            "step" => Some(HitMode::Step),
            _ => None,
        }
    }

    /// The name `parse` accepts.
    pub fn as_str(self) -> &'static str {
        match self {
            HitMode::Exact => "exact",
            HitMode::Step => "step",
        }
    }
}

impl Default for RenderOptions {
    fn default() -> Self {
        RenderOptions {
            iso: 0.5,
            width: 256,
            height: 256,
            azimuth: 30.0,
            elevation: 25.0,
            perspective: false,
            skip: true,
            skip_map: Default::default(),
            step: 0.25,
            block: 4,
            frames: 3,
            progress: false,
            hit: HitMode::default(),
            volume: Default::default(),
            shade: Shade::default(),
        }
    }
}

/// The uniform block of the ray caster (layout checked against naga in tests).
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
pub struct RayParams {
    /// Eye, view and valid box (the block every ray caster starts with).
    pub camera: crate::render::camera::CameraUniform,
    pub shade: [f32; 4],
    pub image: [i32; 4],
    pub blocks: [i32; 4],
}

pub struct Frame {
    pub width: u32,
    pub height: u32,
    /// RGBA8, row-major from the top.
    pub rgba: Vec<u8>,
    /// Median wall time of the timed frames (submit + wait), in ms.
    pub ms_per_frame: f64,
    /// Fraction of blocks whose bounds exclude the iso-value.
    pub empty_blocks: f64,
    /// The skipping map's build time and size (None: none built).
    pub skip_map: Option<crate::render::blocks::SkipMapStats>,
}

/// The xyz of a uniform vector, widened to f64 (exactly).
pub(crate) fn d3(a: [f32; 4]) -> DVec3 {
    Vec3::from_slice(&a[..3]).as_dvec3()
}

/// [`valid_box`] as glam vectors.
fn valid_box_vec(d: &Derivation, vol: &LatticeVolume) -> (Vec3, Vec3) {
    box_of(crate::volume::support_radius(d), vol.dims)
}

/// The valid box of a volume of `dims` samples for a support of `radius` cells.
fn box_of(radius: usize, dims: [usize; 3]) -> (Vec3, Vec3) {
    let r = radius as f32;
    let dims = Vec3::new(dims[0] as f32, dims[1] as f32, dims[2] as f32);
    (Vec3::splat(r), dims - 1.0 - r)
}

/// The box where the whole support of every sample used lies in the volume.
pub fn valid_box(d: &Derivation, vol: &LatticeVolume) -> ([f32; 3], [f32; 3]) {
    let (lo, hi) = valid_box_vec(d, vol);
    (lo.to_array(), hi.to_array())
}

pub use crate::render::camera::view_direction;

pub fn ray_params(d: &Derivation, vol: &LatticeVolume, o: &RenderOptions) -> RayParams {
    ray_params_for(crate::volume::support_radius(d), vol.dims, o)
}

/// [`ray_params`] for a volume of `dims` samples and a filter whose support
/// reaches `radius` cells (what a renderer keeps after the upload).
pub(crate) fn ray_params_for(radius: usize, dims: [usize; 3], o: &RenderOptions) -> RayParams {
    let (lo, hi) = box_of(radius, dims);
    let camera = crate::render::Camera { azimuth: o.azimuth, elevation: o.elevation, perspective: o.perspective };
    let blocks = [
        (dims[0] as i32 + o.block - 1) / o.block,
        (dims[1] as i32 + o.block - 1) / o.block,
        (dims[2] as i32 + o.block - 1) / o.block,
        0,
    ];
    RayParams {
        camera: crate::render::camera::CameraUniform::orbit(&camera, lo.to_array(), hi.to_array(), o.width, o.height),
        shade: [o.iso, o.step, o.perspective as i32 as f32, skip_mode(o.skip, o.skip_map)],
        image: [o.width as i32, o.height as i32, o.block, 0],
        blocks,
    }
}

/// The ray caster's skipping mode (`shade.w`): 0 off, 1 one block at a
/// time, 2 by the distance map after the bounds.
pub(crate) fn skip_mode(skip: bool, map: crate::render::blocks::SkipMap) -> f32 {
    match (skip, map) {
        (false, _) => 0.0,
        (true, crate::render::blocks::SkipMap::OneBlock) => 1.0,
        (true, _) => 2.0,
    }
}

/// Renders one isosurface image on the device.
pub fn render(
    gpu: &Gpu,
    d: &Derivation,
    vol: &LatticeVolume,
    layout: Layout,
    o: &RenderOptions,
) -> Result<Frame, RenderError> {
    render_with_depth(gpu, d, vol, layout, o).map(|(frame, _)| frame)
}

/// The whole ray-casting shader of a filter: its emitted module (`command`
/// named in the header) and the ray caster of `hit`. The exact walk's fine
/// bounds grid (edge, blocks per axis) are pipeline-overridable constants
/// with `fine` as their defaults, so the browser viewer runs the same source
/// on any volume (`boxforge web`).
pub fn raycast_shader(
    d: &Derivation,
    layout: Layout,
    hit: HitMode,
    fine: (i32, [i32; 3]),
    command: &str,
) -> Result<String, RenderError> {
    let opts = EmitOptions { layout, command: command.into(), ..Default::default() };
    raycast_shader_with(d, &opts, hit, fine, false, &Shade::default())
}

/// [`raycast_shader`], with `host_depth` the host-depth input of
/// [`renderer::IsoRenderer`] (group 1, bindings 6 and 7) and the shading.
pub(crate) fn raycast_shader_with(
    d: &Derivation,
    module: &EmitOptions,
    hit: HitMode,
    fine: (i32, [i32; 3]),
    host_depth: bool,
    shade: &Shade,
) -> Result<String, RenderError> {
    check_shade(d, shade)?;
    let module = emit(d, module)?;
    let plan = HitPlan::new(d);
    let exact = (hit == HitMode::Exact).then_some((&plan, fine.0, fine.1));
    let curvature = shade.mode.needs_hessian();
    let shading = if curvature { shade.wgsl(&d.filter.name) } else { String::new() };
    Ok(format!("{}\n{}{shading}", module.source, template::template(&d.filter.name, exact, host_depth, curvature)))
}

/// Curvature shading needs `<f>_eval_hessian` (degree >= 2) and positive
/// radius and thickness.
pub fn check_shade(d: &Derivation, shade: &Shade) -> Result<(), RenderError> {
    if shade.mode.needs_hessian() && d.facts.degree < 2 {
        return Err(RenderError::ShadeNeedsDegree {
            mode: shade.mode.name(),
            filter: d.filter.name.clone(),
            degree: d.facts.degree,
        });
    }
    if !(shade.radius.is_finite() && shade.radius > 0.0 && shade.thickness.is_finite() && shade.thickness > 0.0) {
        return Err(RenderError::ShadeControls { radius: shade.radius, thickness: shade.thickness });
    }
    Ok(())
}

/// The fine grid of the exact walk for a volume of `dims` and coarse blocks
/// of `block` cubes: (edge, blocks per axis); see [`fine_edge`].
pub fn fine_grid(dims: [usize; 3], block: i32) -> (i32, [i32; 3]) {
    let e = fine_edge(dims, block);
    (e, dims.map(|n| n.div_ceil(e as usize) as i32))
}

/// The edge of the fine bounds grid of the exact walk: 1 (one bound per unit
/// cube) unless the grid would need more than 65535 workgroups of 64 to fill.
pub fn fine_edge(dims: [usize; 3], coarse: i32) -> i32 {
    let mut e = 1i32;
    while e < coarse.max(1) {
        let blocks: usize = dims.iter().map(|&n| n.div_ceil(e as usize)).product();
        if blocks.div_ceil(64) <= 65535 {
            break;
        }
        e *= 2;
    }
    e
}

/// [`render`], and the ray parameter t of every pixel's hit (-1 for a miss):
/// an [`IsoRenderer`](renderer::IsoRenderer) built for this one call (shader
/// compiled, samples uploaded), its frames timed and read back.
pub fn render_with_depth(
    gpu: &Gpu,
    d: &Derivation,
    vol: &LatticeVolume,
    layout: Layout,
    o: &RenderOptions,
) -> Result<(Frame, Vec<f32>), RenderError> {
    let dv = DeviceVolume::with_options(gpu, vol, layout, &o.volume)?;
    let mut iso = renderer::IsoRenderer::new(gpu, d, &dv, renderer::IsoOptions::from(o))?;
    iso.timed_frames(o)
}

#[cfg(feature = "files")]
/// Writes RGBA8 pixels as a PNG.
/// Writes an RGBA PNG atomically (a temporary file renamed over `path`), so
/// an interrupted run leaves either the old image or the new one.
pub fn write_png(path: &std::path::Path, width: u32, height: u32, rgba: &[u8]) -> std::io::Result<()> {
    if let Some(dir) = path.parent().filter(|p| !p.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir)?;
    }
    let mut bytes = Vec::new();
    {
        let mut enc = png::Encoder::new(&mut bytes, width, height);
        enc.set_color(png::ColorType::Rgba);
        enc.set_depth(png::BitDepth::Eight);
        let mut w = enc.write_header().map_err(std::io::Error::other)?;
        w.write_image_data(rgba).map_err(std::io::Error::other)?;
    }
    boxforge::build::output::write_atomic(path, &bytes).map_err(|e| std::io::Error::other(e.to_string()))
}
