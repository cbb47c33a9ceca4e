//! `render`'s flags checked into a typed request, before any work: every
//! refusal that the flags alone (and the filter's definition) decide comes
//! from here, so a bad combination is named before the volume is read, the
//! transfer function loaded or a device opened. The work (core.rs,
//! paged.rs, four.rs) takes the checked request and never looks at a flag.

use super::dvr::How;
use super::{CacheArg, HitArg, ModeArg, RenderArgs, RendererArg, ShadeArg};
use crate::common::{parse_view, Failure};
use crate::request::{self, TfChoice};
use boxforge::emit::Layout;
use boxforge::spec::{self, lattice::Lattice, Filter};
use boxforge_runtime::render::blocks::SkipMap;
use boxforge_runtime::render::iso::{HitMode, Shade, ShadeMode};
use boxforge_runtime::render::schemes::Scheme;
use boxforge_runtime::volume::SampleFormat;
use std::path::PathBuf;

/// A checked `render`: a 3D filter's frame, or a 4D filter's time series.
pub enum RenderRequest {
    Three(Box<ThreeRequest>),
    Four(Box<FourRequest>),
}

/// What every render shares: the image, the camera, the ray, the output.
pub struct Frame {
    /// Image edge in pixels (checked against [`request::MAX_IMAGE_EDGE`]).
    pub size: u32,
    pub azimuth: f32,
    pub elevation: f32,
    pub perspective: bool,
    /// Ray step in cells.
    pub step: f32,
    pub iso: f32,
    pub out: PathBuf,
    pub adapter: Option<String>,
}

/// Where the samples come from (`--volume`, `--raw`, `--resample`).
pub struct Source {
    pub volume: String,
    pub raw: Option<String>,
    /// Resample a Cartesian volume on the lattice (else its lattice subset).
    pub resample: bool,
    /// Some for an OME-Zarr store: the level, channel and time point to read.
    pub zarr: Option<boxforge_runtime::volume::zarr::Selection>,
}

/// What a 3D render draws.
pub enum Look {
    /// An isosurface, hit as `--hit` says.
    Iso(HitMode),
    /// A volume rendering.
    Dvr(DvrLook),
}

/// `--mode dvr`'s choices.
pub struct DvrLook {
    pub tf: TfChoice,
    pub preintegrate: bool,
    /// `--tf-curvature`: the curvature transfer function at this radius.
    pub curvature: Option<f32>,
    pub how: How,
}

/// `--gpu-budget` and its companions: out of core.
pub struct PagedRequest {
    pub budget: u64,
    pub stats_json: bool,
    /// Read and keep the block bounds in the cache folder.
    pub bounds_cache: bool,
}

/// A checked 3D render.
pub struct ThreeRequest {
    pub frame: Frame,
    pub source: Source,
    /// The filter as resolved (bcc_linear for a hand-written scheme), before
    /// its view variant (chosen with the derivation).
    pub filter: Filter,
    /// `--filter mattausch_bilinear[_spatial]`.
    pub scheme: Option<Scheme>,
    pub look: Look,
    /// The isosurface shading; for `--tf-curvature`, the curvature it colours
    /// by (what the derivation must support).
    pub shade: Shade,
    pub skip: bool,
    pub skip_map: SkipMap,
    pub layout: Layout,
    pub format: SampleFormat,
    pub brick: Option<usize>,
    pub paged: Option<PagedRequest>,
}

/// `--time` / `--frames` of a 4D filter.
pub enum Times {
    /// One frame at this time (checked against the series once loaded).
    At(f32),
    /// An animation of this many frames (at least one) over the series.
    Frames(usize),
    /// One frame in the middle of the series.
    Middle,
}

/// A checked 4D render (orthographic, in core).
pub struct FourRequest {
    pub frame: Frame,
    pub source: Source,
    pub filter: Filter,
    pub layout: Layout,
    pub exact: bool,
    /// Some for `--mode dvr`.
    pub tf: Option<TfChoice>,
    pub times: Times,
}

impl RenderRequest {
    /// Checks the flags: the filter decides 3D or 4D (a spec file is read
    /// for it), then each kind's combinations, in the order the refusals
    /// have always come.
    pub fn from_args(a: RenderArgs) -> Result<RenderRequest, Failure> {
        let scheme = Scheme::parse(&a.filter);
        let resolved = spec::resolve(if scheme.is_some() { "bcc_linear" } else { &a.filter });
        match resolved {
            // 4D filters draw a time series at any t (render/four.rs).
            Ok(f) if scheme.is_none() && f.dim() == 4 => Ok(RenderRequest::Four(Box::new(four(a, f)?))),
            resolved => Ok(RenderRequest::Three(Box::new(three(a, scheme, resolved)?))),
        }
    }
}

/// The frame's numbers and the output file, checked.
fn frame(a: &RenderArgs) -> Result<Frame, Failure> {
    let (azimuth, elevation) = parse_view(&a.view)?;
    request::check_render_numbers(a.size, a.step, a.iso, azimuth, elevation)?;
    request::check_output_file(&a.out, "--out")?;
    Ok(Frame {
        size: a.size,
        azimuth,
        elevation,
        perspective: a.perspective,
        step: a.step,
        iso: a.iso,
        out: a.out.clone(),
        adapter: a.adapter.clone(),
    })
}

/// Where the samples come from; `--lod`, `--channel` (and `--time` with a
/// 3D filter) only for an OME-Zarr store.
fn source(a: &RenderArgs, three_d: bool) -> Result<Source, Failure> {
    use boxforge_runtime::volume::zarr::{is_store, Selection};
    let store = is_store(std::path::Path::new(&a.volume));
    let zarr = if store {
        if a.raw.is_some() {
            return Err(Failure(format!(
                "--raw reads headerless files; {} is an OME-Zarr store: drop --raw",
                a.volume
            )));
        }
        let time = match a.time.filter(|_| three_d) {
            None => 0,
            Some(t) if t >= 0.0 && t.fract() == 0.0 => t as usize,
            Some(t) => {
                return Err(Failure(format!(
                    "--time {t}: with a 3D filter, --time picks a time point of the store: give a whole number from 0"
                )))
            }
        };
        Some(Selection { level: a.lod.unwrap_or(0), channel: a.channel.unwrap_or(0), time })
    } else {
        for (flag, given) in [("--lod", a.lod.is_some()), ("--channel", a.channel.is_some())] {
            if given {
                return Err(Failure(format!(
                    "{flag} picks from an OME-Zarr store; {} is not one: drop {flag}",
                    a.volume
                )));
            }
        }
        None
    };
    Ok(Source { volume: a.volume.clone(), raw: a.raw.clone(), resample: a.resample, zarr })
}

/// The shading `--shade`, `--curvature-radius` and `--contour-thickness` give.
fn shade(a: &RenderArgs) -> Shade {
    Shade { mode: a.shade.into(), radius: a.curvature_radius, thickness: a.contour_thickness }
}

fn three(a: RenderArgs, scheme: Option<Scheme>, resolved: boxforge::Result<Filter>) -> Result<ThreeRequest, Failure> {
    let zarr_time = a.time.is_some() && boxforge_runtime::volume::zarr::is_store(std::path::Path::new(&a.volume));
    if (a.time.is_some() && !zarr_time) || a.frames.is_some() {
        return Err(Failure(format!(
            "--time and --frames draw time series with a 4D filter; {} is not one (see boxforge list: d4star8, z4_cubic, ...)",
            a.filter
        )));
    }
    let frame = frame(&a)?;
    let tf = request::check_render_mode(a.mode, a.tf.as_deref(), a.no_preintegration)?;
    let perm = request::check_cache(a.cache, a.mode, a.qc, a.qc_grad)?;
    if a.peel && perm.is_none() {
        return Err(Failure("--peel peels the PERM cache: add --cache perm (with --mode dvr)".into()));
    }
    let pt = request::check_renderer(a.renderer, a.mode, a.cache, a.perspective)?;
    let layout = Layout::from(a.layout);
    let shade = shade(&a);
    // Curvature comes from eval_hessian in the ray casters only.
    let other_renderer = if perm.is_some() {
        Some("--cache perm")
    } else if pt {
        Some("--renderer pt")
    } else if a.gpu_budget.is_some() {
        Some("--gpu-budget")
    } else if scheme.is_some() {
        Some("a hand-written scheme")
    } else {
        None
    };
    if shade.mode.needs_hessian() {
        if let Some(other) = if tf.is_some() { Some("--mode dvr") } else { other_renderer } {
            return Err(Failure(format!(
                "--shade {} colours the isosurfaces of the ray caster, not {other}: drop one of them",
                shade.mode.name()
            )));
        }
    }
    if a.tf_curvature {
        let other =
            if tf.is_none() { Some("isosurfaces (add --mode dvr, or use --shade curvature)") } else { other_renderer };
        if let Some(other) = other {
            return Err(Failure(format!(
                "--tf-curvature is a transfer function of the DVR ray caster, not of {other}: drop one of them"
            )));
        }
    }
    request::check_shade_numbers(&shade)?;
    let budget = a.gpu_budget.as_deref().map(request::parse_budget).transpose()?;
    match budget {
        Some(_) => request::check_paged(a.hit == HitArg::Exact, layout, perm.is_some() || pt || scheme.is_some())
            .and_then(|()| request::check_brick(a.brick, Layout::Bricked))?,
        None => request::check_brick(a.brick, layout)?,
    }
    // Mattausch et al.'s hand-written plane-stack schemes: ray-cast DVR on BCC only.
    if let Some(s) = scheme {
        request::check_scheme(s.name(), a.mode, a.cache, pt, layout)?;
    }
    let format = SampleFormat::from(a.format);
    if (format != SampleFormat::F32 || layout.is_bricked()) && (scheme.is_some() || pt) {
        return Err(Failure(
            "--format and --layout bricked store the samples of the spline ray casters (iso, DVR, PERM); the schemes and --renderer pt read f32 embedded samples: drop them or use the ray casters".into(),
        ));
    }
    if budget.is_some() && a.resample {
        return Err(Failure(
            "--gpu-budget reads the file lazily as the lattice subset; --resample needs the whole volume in memory: drop one of them".into(),
        ));
    }
    let f = resolved?;
    if f.dim() != 3 {
        return Err(Failure(format!("{} is {}D: render needs a 3D filter", f.name, f.dim())));
    }
    let lat = match &a.lattice {
        Some(l) => Lattice::builtin(l)?,
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
    request::check_ml_volume(&a.volume, &lat)?;
    let look = match tf {
        None => Look::Iso(a.hit.into()),
        Some(tf) => Look::Dvr(DvrLook {
            tf,
            preintegrate: !a.no_preintegration,
            curvature: a.tf_curvature.then_some(a.curvature_radius),
            how: match (scheme, perm) {
                (Some(s), _) => How::Scheme(s),
                _ if pt => How::Pt(a.shading.into()),
                (None, Some(q)) => How::Perm(q, a.peel),
                (None, None) => How::RayCast,
            },
        }),
    };
    Ok(ThreeRequest {
        source: source(&a, true)?,
        frame,
        filter: f,
        scheme,
        look,
        shade: if a.tf_curvature { Shade { mode: ShadeMode::Curvature, ..shade } } else { shade },
        skip: !a.no_skip,
        skip_map: if a.skip_one_block { SkipMap::OneBlock } else { SkipMap::Distance },
        layout,
        format,
        brick: a.brick,
        paged: budget.map(|budget| PagedRequest { budget, stats_json: a.stats_json, bounds_cache: !a.no_bounds_cache }),
    })
}

fn four(a: RenderArgs, f: Filter) -> Result<FourRequest, Failure> {
    let frame = frame(&a)?;
    // What the 4D renderer does not do yet, refused by name.
    let refuse = |flag: &str| -> Result<FourRequest, Failure> {
        Err(Failure(format!(
            "{flag} is not offered for 4D filters yet (orthographic isosurfaces and DVR, in core): drop it"
        )))
    };
    let tf = request::check_render_mode(a.mode, a.tf.as_deref(), a.no_preintegration)?;
    let dvr = a.mode == ModeArg::Dvr;
    if dvr && (a.no_preintegration || a.tf_curvature) {
        return refuse("--no-preintegration/--tf-curvature");
    }
    if a.gpu_budget.is_some() {
        return refuse("--gpu-budget");
    }
    let exact = a.hit != HitArg::Step;
    if exact && dvr {
        return Err(Failure("--hit exact finds isosurfaces; DVR samples fixed steps: drop --hit or --mode dvr".into()));
    }
    if a.shade != ShadeArg::Phong {
        return refuse("--shade");
    }
    if a.cache != CacheArg::None || a.renderer != RendererArg::Raycast {
        return refuse("--cache/--renderer");
    }
    if a.perspective {
        return refuse("--perspective");
    }
    let layout = Layout::from(a.layout);
    if layout.is_bricked() {
        return Err(Failure(format!(
            "--layout {}: 4D samples are a storage buffer; use --layout embedded or packed",
            layout.name()
        )));
    }
    let times = match (a.time, a.frames) {
        (Some(_), Some(_)) => return Err(Failure("--time draws one frame and --frames an animation: give one".into())),
        (Some(t), None) => Times::At(t),
        (None, Some(0)) => return Err(Failure("--frames 0: give at least 1 frame".into())),
        (None, Some(n)) => Times::Frames(n),
        (None, None) => Times::Middle,
    };
    Ok(FourRequest { source: source(&a, false)?, frame, filter: f, layout, exact, tf, times })
}
