//! `boxforge render`: an isosurface, or with --mode dvr a direct volume
//! rendering (ray cast, PERM-cached, projected tetrahedra or a hand-written
//! scheme: see dvr.rs), to PNG on the GPU.

mod dvr;
mod four;
mod paged;

use crate::common::{parse_view, Failure, FormatArg, LayoutArg};
use crate::request;
use boxforge::derive::Derivation;
use boxforge::emit::Layout;
use boxforge::spec;
use boxforge_runtime::gpu::Gpu;
use boxforge_runtime::render::dvr::transfer::TransferFunction;
use boxforge_runtime::render::iso::{self as render, HitMode, RenderOptions, Shade, ShadeMode};
use boxforge_runtime::render::schemes::Scheme;
use boxforge_runtime::scene::{self, Conversion};

#[derive(clap::Args)]
pub struct RenderArgs {
    /// iso: isosurface; dvr: emission-absorption volume rendering with --tf.
    #[arg(long, value_enum, default_value = "iso")]
    mode: ModeArg,
    /// Transfer function for --mode dvr: a preset (mni-tissue, mni-opaque, marschner-lobb) or a JSON file.
    #[arg(long)]
    tf: Option<String>,
    /// --mode dvr: point-sample the transfer function (opacity-corrected) instead of pre-integrating.
    #[arg(long)]
    no_preintegration: bool,
    /// --mode dvr: none, or perm (precompute density and gradient at quantized positions of the cells
    /// the transfer function shows, and look them up; Lim and Shin's PERM).
    #[arg(long, value_enum, default_value = "none")]
    cache: CacheArg,
    /// --mode dvr: raycast, or pt (projected tetrahedra, Mattausch et al.: the Delaunay tetrahedra of
    /// BCC or the Kuhn tetrahedra of CC cubes rasterised back to front, barycentric interpolation,
    /// orthographic; the filter sets the lattice and the clipped box).
    #[arg(long, value_enum, default_value = "raycast")]
    renderer: RendererArg,
    /// --renderer pt: gouraud (lighting at the vertices) or phong (per fragment), with smooth vertex normals.
    #[arg(long, value_enum, default_value = "phong")]
    shading: dvr::ShadingArg,
    /// --cache perm: density positions per cell axis (N^3 per cell; default 5).
    #[arg(long)]
    qc: Option<u32>,
    /// --cache perm: gradient positions per cell axis (M^3 per cell; default --qc).
    #[arg(long)]
    qc_grad: Option<u32>,
    /// --cache perm: opaque-boundary peeling (drop the cached cells no ray reaches before it
    /// terminates; the image is unchanged for views from outside the volume).
    #[arg(long)]
    peel: bool,
    #[arg(long)]
    filter: String,
    /// `ml:N` (Marschner-Lobb, about N^3 samples), a .nii/.nii.gz file, or a raw file with --raw;
    /// with a 4D filter a time series: `ml-drift:N,F` (the drifting Marschner-Lobb signal, N^3
    /// samples in F frames), a 4D .nii/.nii.gz, or a folder of numbered raw frames with --raw.
    #[arg(long)]
    volume: String,
    /// Raw volume format: nx,ny,nz,type (type u8, u16 or f32).
    #[arg(long)]
    raw: Option<String>,
    /// Data lattice (default: the filter's).
    #[arg(long)]
    lattice: Option<String>,
    /// Lattice subset of a Cartesian volume (default).
    #[arg(long, conflicts_with = "resample")]
    subset: bool,
    /// Resample a Cartesian volume on the lattice at a matched sample count.
    #[arg(long)]
    resample: bool,
    #[arg(long, default_value_t = 0.5, allow_negative_numbers = true)]
    iso: f32,
    #[arg(long, default_value_t = 512)]
    size: u32,
    /// Azimuth,elevation in degrees.
    #[arg(long, default_value = "30,25", allow_hyphen_values = true)]
    view: String,
    #[arg(long)]
    perspective: bool,
    /// Turn empty-space skipping off.
    #[arg(long)]
    no_skip: bool,
    /// Skip one empty block at a time (the skipping before the distance map)
    /// instead of jumping over the whole empty box a block's distance to the
    /// nearest occupied block guarantees.
    #[arg(long, conflicts_with = "no_skip")]
    skip_one_block: bool,
    /// Ray step in cells.
    #[arg(long, default_value_t = 0.25, allow_negative_numbers = true)]
    step: f32,
    /// First hit: exact (ray cut at knot planes, Bernstein root isolation: no thin
    /// feature missed) or fixed steps of --step (default: the faster one on lavapipe).
    #[arg(long, value_enum, default_value = "step")]
    hit: HitArg,
    /// How isosurface hits are coloured: Blinn-Phong, or from the principal
    /// curvatures k1, k2 of `<f>_eval_hessian` (Kindlmann et al. 2003):
    /// a (k1, k2) colormap (convex red, concave blue, saddle green), mean or
    /// Gaussian curvature, ridges and valleys, or view-dependent contours.
    /// Needs a filter of degree >= 2; warns for C^1 filters (the Hessian
    /// jumps across knot planes).
    #[arg(long, value_enum, default_value = "phong")]
    shade: ShadeArg,
    /// With --mode dvr: the curvature transfer function, a 2D transfer
    /// function over (k1, k2) of `<f>_eval_hessian` (Kindlmann et al. 2003):
    /// colour by the (k1, k2) colormap, the value transfer function's opacity
    /// scaled down on flat sheets (0.25 + 0.75 min(max(|k1|, |k2|) R, 1)).
    #[arg(long)]
    tf_curvature: bool,
    /// With --shade or --tf-curvature: the radius of curvature in cells at which the colours
    /// saturate (|k| * radius = 1).
    #[arg(long, default_value_t = 4.0, allow_negative_numbers = true)]
    curvature_radius: f32,
    /// With --shade contours: Kindlmann's contour thickness T in cells.
    #[arg(long, default_value_t = 1.0, allow_negative_numbers = true)]
    contour_thickness: f32,
    #[arg(long, value_enum, default_value = "embedded")]
    layout: LayoutArg,
    /// Brick edge in lattice texels (with --layout bricked; the halo is the
    /// filter's stencil reach + 1).
    #[arg(long)]
    brick: Option<usize>,
    /// How samples are stored on the device: f32, or compact f16, u16 or u8
    /// (normalized over the data range; the error is stated).
    #[arg(long, value_enum, default_value = "f32")]
    format: FormatArg,
    /// Render out of core within this much device memory (e.g. 256MiB,
    /// 2GiB): bricks are paged into a pool as rays reach them, in passes.
    #[arg(long)]
    gpu_budget: Option<String>,
    /// With --gpu-budget: render a second (warm) frame and print both
    /// frames' statistics and the peak host memory as JSON on stdout (what
    /// `bench --volumes` reads).
    #[arg(long, requires = "gpu_budget", hide = true)]
    stats_json: bool,
    /// With --gpu-budget: compute the block bounds again instead of reading
    /// them from the cache folder (where a render of the same file, filter
    /// and storage keeps them).
    #[arg(long, requires = "gpu_budget")]
    no_bounds_cache: bool,
    #[arg(long)]
    adapter: Option<String>,
    /// 4D filters: the time to draw, in frames of the series (any real in
    /// 0..frames-1, not only the sampled ones; default: the middle).
    #[arg(long, allow_negative_numbers = true)]
    time: Option<f32>,
    /// 4D filters: an animation of N frames over the whole series, written
    /// as numbered PNGs beside --out (out-0000.png, ...).
    #[arg(long, conflicts_with = "time")]
    frames: Option<usize>,
    #[arg(long, default_value = "out.png")]
    out: std::path::PathBuf,
}

/// `--skip-one-block`: the map of one-block skipping, else the distance map.
/// The DVR options the flags give for a `size`^2 frame seen from `view`
/// (azimuth, elevation), in core and out of core alike.
fn dvr_options(a: &RenderArgs, size: u32, view: (f32, f32)) -> boxforge_runtime::render::dvr::DvrOptions {
    boxforge_runtime::render::dvr::DvrOptions {
        width: size,
        height: size,
        azimuth: view.0,
        elevation: view.1,
        perspective: a.perspective,
        skip: !a.no_skip,
        skip_map: skip_map(a.skip_one_block),
        preintegrate: !a.no_preintegration,
        step: a.step,
        ..Default::default()
    }
}

fn skip_map(one_block: bool) -> boxforge_runtime::render::blocks::SkipMap {
    use boxforge_runtime::render::blocks::SkipMap;
    if one_block {
        SkipMap::OneBlock
    } else {
        SkipMap::Distance
    }
}

/// `--mode`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
enum ModeArg {
    Iso,
    Dvr,
}

/// `--cache`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
enum CacheArg {
    None,
    Perm,
}

/// `--renderer`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
enum RendererArg {
    Raycast,
    Pt,
}

/// `--shade`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
enum ShadeArg {
    Phong,
    Curvature,
    Mean,
    Gaussian,
    Ridges,
    Contours,
}

impl From<ShadeArg> for ShadeMode {
    fn from(s: ShadeArg) -> ShadeMode {
        match s {
            ShadeArg::Phong => ShadeMode::Phong,
            ShadeArg::Curvature => ShadeMode::Curvature,
            ShadeArg::Mean => ShadeMode::Mean,
            ShadeArg::Gaussian => ShadeMode::Gaussian,
            ShadeArg::Ridges => ShadeMode::Ridges,
            ShadeArg::Contours => ShadeMode::Contours,
        }
    }
}

/// `--hit`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
enum HitArg {
    Exact,
    Step,
}

impl From<HitArg> for HitMode {
    fn from(h: HitArg) -> HitMode {
        match h {
            HitArg::Exact => HitMode::Exact,
            HitArg::Step => HitMode::Step,
        }
    }
}

// The request checks of the library take the words of the command line.
impl ModeArg {
    fn name(self) -> &'static str {
        match self {
            ModeArg::Iso => "iso",
            ModeArg::Dvr => "dvr",
        }
    }
}

impl CacheArg {
    fn name(self) -> &'static str {
        match self {
            CacheArg::None => "none",
            CacheArg::Perm => "perm",
        }
    }
}

impl RendererArg {
    fn name(self) -> &'static str {
        match self {
            RendererArg::Raycast => "raycast",
            RendererArg::Pt => "pt",
        }
    }
}

pub fn run(a: RenderArgs) -> Result<(), Failure> {
    // 4D filters draw a time series at any t (render/four.rs).
    if Scheme::parse(&a.filter).is_none() {
        if let Ok(f) = spec::resolve(&a.filter) {
            if f.dim() == 4 {
                let d = Derivation::new(&f)?;
                return four::run(&a, &d);
            }
        }
    }
    if a.time.is_some() || a.frames.is_some() {
        return Err(Failure(format!(
            "--time and --frames draw time series with a 4D filter; {} is not one (see boxforge list: d4star8, z4_cubic, ...)",
            a.filter
        )));
    }
    let (az, el) = parse_view(&a.view)?;
    let (size, mode, cache) = (a.size, a.mode.name(), a.cache.name());
    request::check_render_numbers(size, a.step, a.iso, az, el)?;
    request::check_output_file(&a.out, "--out")?;
    let dvr = request::check_render_mode(mode, a.tf.as_deref(), a.no_preintegration)?;
    let perm = request::check_cache(cache, mode, a.qc, a.qc_grad)?;
    if a.peel && perm.is_none() {
        return Err(Failure("--peel peels the PERM cache: add --cache perm (with --mode dvr)".into()));
    }
    let pt = request::check_renderer(a.renderer.name(), mode, cache, a.perspective)?;
    // An empty name: no --tf given, the default ramp once the data's range is known.
    let mut tf = match &dvr {
        Some(name) if !name.is_empty() => Some(TransferFunction::load(name).map_err(|e| Failure(format!("--tf {e}")))?),
        _ => None,
    };
    let layout = Layout::from(a.layout);
    let shade = Shade { mode: a.shade.into(), radius: a.curvature_radius, thickness: a.contour_thickness };
    // Curvature comes from eval_hessian in the ray casters only.
    let other_renderer = if perm.is_some() {
        Some("--cache perm")
    } else if pt {
        Some("--renderer pt")
    } else if a.gpu_budget.is_some() {
        Some("--gpu-budget")
    } else if Scheme::parse(&a.filter).is_some() {
        Some("a hand-written scheme")
    } else {
        None
    };
    if shade.mode.needs_hessian() {
        if let Some(other) = if dvr.is_some() { Some("--mode dvr") } else { other_renderer } {
            return Err(Failure(format!(
                "--shade {} colours the isosurfaces of the ray caster, not {other}: drop one of them",
                shade.mode.name()
            )));
        }
    }
    if a.tf_curvature {
        let other =
            if dvr.is_none() { Some("isosurfaces (add --mode dvr, or use --shade curvature)") } else { other_renderer };
        if let Some(other) = other {
            return Err(Failure(format!(
                "--tf-curvature is a transfer function of the DVR ray caster, not of {other}: drop one of them"
            )));
        }
    }
    let budget = a.gpu_budget.as_deref().map(request::parse_budget).transpose()?;
    match budget {
        Some(_) => request::check_paged(
            matches!(a.hit, HitArg::Exact),
            layout,
            perm.is_some() || pt || Scheme::parse(&a.filter).is_some(),
        )
        .and_then(|()| request::check_brick(a.brick, Layout::Bricked))?,
        None => request::check_brick(a.brick, layout)?,
    }
    // Mattausch et al.'s hand-written plane-stack schemes: ray-cast DVR on BCC only.
    let scheme = Scheme::parse(&a.filter);
    if let Some(s) = scheme {
        request::check_scheme(s.name(), mode, cache, pt, layout.name())?;
    }
    let mut f = match scheme {
        Some(_) => spec::resolve("bcc_linear")?,
        None => spec::resolve(&a.filter)?,
    };
    if f.view_dependent {
        // The variant for this frame's view (Mattausch et al.: shear
        // planes and shear direction follow the view direction).
        let (f_view, choice) = f.view_variant(render::view_direction(az, el))?;
        eprintln!("{choice}");
        f = f_view;
    }
    let d = Derivation::new(&f)?;
    if d.facts.dim != 3 {
        return Err(Failure(format!("{} is {}D: render needs a 3D filter", f.name, d.facts.dim)));
    }
    let curvature_shade = if a.tf_curvature { Shade { mode: ShadeMode::Curvature, ..shade } } else { shade };
    render::check_shade(&d, &curvature_shade).map_err(|e| match e {
        boxforge_runtime::gpu::GpuError::Runtime(m) => Failure(m),
        e => Failure(e.to_string()),
    })?;
    if curvature_shade.mode.needs_hessian() && d.facts.continuity < 2 {
        eprintln!(
            "warning: {} is C^{}: its Hessian jumps across knot planes, so curvature is discontinuous there (C^2 filters such as bcc7 or cc_tricubic give smooth curvature)",
            d.filter.name,
            d.facts.continuity,
        );
    }
    let lat = match &a.lattice {
        Some(l) => boxforge::spec::lattice::Lattice::builtin(l)?,
        None => f.lattice.clone(),
    };
    if lat != f.lattice {
        return Err(Failure(format!(
            "filter {} is defined on the {} lattice, not {}: pick a filter for that lattice",
            f.name, f.lattice.name, lat.name
        )));
    }
    if pt && boxforge_runtime::render::pt::tets::Grid::of(&lat).is_none() {
        return Err(Failure(format!(
            "--renderer pt has tetrahedral meshes for BCC and CC data, not the {} lattice of {}: pick a BCC or CC filter, or drop --renderer pt",
            lat.name, f.name
        )));
    }
    let conversion = if a.resample { Conversion::Resample } else { Conversion::Subset };
    request::check_ml_volume(&a.volume, &lat)?;
    if let Some(budget) = budget {
        if a.resample {
            return Err(Failure(
                "--gpu-budget reads the file lazily as the lattice subset; --resample needs the whole volume in memory: drop one of them".into(),
            ));
        }
        let options = boxforge_runtime::render::paged::PagedOptions {
            iso: a.iso,
            step: a.step,
            brick: a.brick.unwrap_or(boxforge_runtime::volume::BrickShape::DEFAULT_EDGE),
            format: a.format.into(),
            budget,
            max_pixels: size as u64 * size as u64,
            bounds_cache: (!a.no_bounds_cache).then(boxforge_runtime::volume::default_cache_dir),
            ..Default::default()
        };
        let camera = RenderOptions {
            width: size,
            height: size,
            azimuth: az,
            elevation: el,
            perspective: a.perspective,
            frames: 0,
            ..RenderOptions::default()
        };
        let source = paged::open_source(&a.volume, a.raw.as_deref(), &lat)?;
        let what = match (&dvr, tf) {
            (None, _) => paged::Paged::Iso(camera),
            (Some(_), tf) => {
                let tf = match tf {
                    Some(tf) => tf,
                    None => {
                        // No --tf: the default ramp over the samples' range (one pass over the source).
                        let (lo, hi) = source.sample_range().map_err(|e| Failure(e.to_string()))?;
                        let ramp = TransferFunction::ramp(lo as f64, hi as f64);
                        eprintln!(
                            "no --tf given: using the default transfer function, a {} (give --tf to choose one)",
                            ramp.name
                        );
                        ramp
                    }
                };
                let o = dvr_options(&a, size, (az, el));
                let look = boxforge_runtime::render::dvr::DvrLook::from(&o);
                paged::Paged::Dvr(tf.table(), look, o)
            }
        };
        // Before the device starts its threads (see the function's doc).
        boxforge_runtime::memory::one_heap_arena();
        let gpu = Gpu::new(a.adapter.as_deref()).map_err(|e| Failure(e.to_string()))?;
        request::check_image_limits(size, &gpu.limits())?;
        return paged::render(&gpu, &d, source.as_ref(), options, what, &a.out, a.stats_json);
    }
    let vol = scene::load(&a.volume, a.raw.as_deref(), &lat, conversion).map_err(|e| Failure(e.to_string()))?;
    let (lo, hi) = vol.data.iter().fold((f32::INFINITY, f32::NEG_INFINITY), |(a, b), &v| (a.min(v), b.max(v)));
    if dvr.as_deref() == Some("") {
        let ramp = TransferFunction::ramp(lo as f64, hi as f64);
        eprintln!("no --tf given: using the default transfer function, a {} (give --tf to choose one)", ramp.name);
        tf = Some(ramp);
    }
    let warning = match &tf {
        Some(tf) => request::tf_warning(&tf.table(), lo, hi),
        None => request::iso_warning(a.iso, lo, hi),
    };
    if let Some(w) = warning {
        eprintln!("{w}");
    }
    let format = boxforge_runtime::volume::SampleFormat::from(a.format);
    let volume = boxforge_runtime::volume::VolumeOptions {
        format,
        bricks: boxforge_runtime::volume::BrickShape {
            edge: a.brick.unwrap_or(boxforge_runtime::volume::BrickShape::DEFAULT_EDGE),
            halo: boxforge::emit::bricks::brick_halo(&d),
        },
        max_pool_edge: None,
    };
    let custom_volume = format != boxforge_runtime::volume::SampleFormat::F32 || layout.is_bricked();
    if custom_volume && (scheme.is_some() || pt) {
        return Err(Failure(
            "--format and --layout bricked store the samples of the spline ray casters (iso, DVR, PERM); the schemes and --renderer pt read f32 embedded samples: drop them or use the ray casters".into(),
        ));
    }
    format.check_values(&vol.data).map_err(|e| Failure(e.to_string()))?;
    if format != boxforge_runtime::volume::SampleFormat::F32 {
        let (slo, shi) = vol.sample_range();
        eprintln!(
            "samples stored as {}: {} bytes each, at most {:.3e} from the data (half a level over [{slo}, {shi}])",
            format.name(),
            format.bytes(),
            format.max_error(slo, shi)
        );
    }
    let gpu = Gpu::new(a.adapter.as_deref()).map_err(|e| Failure(e.to_string()))?;
    request::check_image_limits(size, &gpu.limits())?;
    let shown = scheme.map_or(f.name.as_str(), |s| s.name());
    eprintln!("rendering {} ({} samples) with {shown} on {} ...", a.volume, vol.samples(), gpu.describe());
    let frame = match &tf {
        Some(tf) => {
            let how = match (scheme, perm) {
                (Some(s), _) => dvr::How::Scheme(s),
                _ if pt => dvr::How::Pt(a.shading.into()),
                (None, Some(q)) => dvr::How::Perm(q, a.peel),
                (None, None) => dvr::How::RayCast,
            };
            let o = boxforge_runtime::render::dvr::DvrOptions {
                progress: true,
                frames: 1,
                volume,
                curvature: a.tf_curvature.then_some(a.curvature_radius),
                ..dvr_options(&a, size, (az, el))
            };
            dvr::frame(&gpu, &d, &vol, layout, tf, &o, how)
        }
        None => {
            let opts = RenderOptions {
                iso: a.iso,
                width: size,
                height: size,
                azimuth: az,
                elevation: el,
                perspective: a.perspective,
                skip: !a.no_skip,
                skip_map: skip_map(a.skip_one_block),
                step: a.step,
                hit: a.hit.into(),
                progress: true,
                frames: 1,
                volume,
                shade,
                ..RenderOptions::default()
            };
            render::render(&gpu, &d, &vol, layout, &opts).map_err(|e| e.to_string())
        }
    }
    .map_err(|e| Failure(request::volume_over_limits(&vol, layout, &gpu.limits()).unwrap_or(e)))?;
    let out = &a.out;
    render::write_png(out, frame.width, frame.height, &frame.rgba)
        .map_err(|e| Failure(format!("cannot write {}: {e}", out.display())))?;
    let map = frame.skip_map.filter(|_| !a.no_skip).map_or(String::new(), |m| {
        format!(
            "; skip map {:.2} ms, {} KiB, mean skip distance {:.1} blocks{}",
            m.build_ms,
            m.bytes.div_ceil(1024),
            m.mean_distance,
            if a.skip_one_block { " (clamped to one block)" } else { "" }
        )
    });
    if tf.is_some() {
        outln!(
            "{}: {}x{} volume rendering in {:.1} ms per frame ({:.0}% of blocks transparent under the transfer function{map})",
            out.display(),
            size,
            size,
            frame.ms_per_frame,
            frame.empty_blocks * 100.0
        );
    } else {
        outln!(
            "{}: {}x{} in {:.1} ms per frame ({:.0}% of blocks empty{map})",
            out.display(),
            size,
            size,
            frame.ms_per_frame,
            frame.empty_blocks * 100.0
        );
    }
    Ok(())
}
