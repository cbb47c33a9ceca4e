//! `boxforge render`: an isosurface, or with --mode dvr a direct volume
//! rendering (ray cast, PERM-cached, projected tetrahedra or a hand-written
//! scheme: see dvr.rs), to PNG on the GPU.
//!
//! The flags are parsed once by clap into typed values ([`RenderArgs`]),
//! checked once into a [`checked::RenderRequest`] before any file is read
//! or device opened, and only the checked request reaches the work: the
//! in-core renderers (core.rs), out of core (paged.rs) or a 4D filter's
//! time series (four.rs).

mod checked;
mod core;
mod dvr;
mod four;
mod look;
mod paged;

pub use crate::choices::{CacheArg, ModeArg, RendererArg};
use crate::common::{Failure, FormatArg, LayoutArg};
use boxforge_runtime::render::iso::{HitMode, ShadeMode};
use checked::RenderRequest;

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
    /// `ml:N` (Marschner-Lobb, about N^3 samples), a .nii/.nii.gz file, a raw file with --raw, or
    /// an OME-Zarr image folder or http:// URL (0.4 or 0.5; with --lod, --channel and, for a t axis, --time N);
    /// with a 4D filter a time series: `ml-drift:N,F` (the drifting Marschner-Lobb signal, N^3
    /// samples in F frames), a 4D .nii/.nii.gz, or a folder of numbered raw frames with --raw.
    #[arg(long)]
    volume: String,
    /// Raw volume format: nx,ny,nz,type (type u8, u16 or f32).
    #[arg(long)]
    raw: Option<String>,
    /// OME-Zarr volumes: the channel to draw (default 0).
    #[arg(long)]
    channel: Option<usize>,
    /// OME-Zarr volumes: the pyramid level to draw (0, the default: the finest).
    #[arg(long)]
    lod: Option<usize>,
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
    /// 0..frames-1, not only the sampled ones; default: the middle). With a 3D filter and an
    /// OME-Zarr volume with a t axis: the time point to draw (default 0).
    #[arg(long, allow_negative_numbers = true)]
    time: Option<f32>,
    /// 4D filters: an animation of N frames over the whole series, written
    /// as numbered PNGs beside --out (out-0000.png, ...).
    #[arg(long, conflicts_with = "time")]
    frames: Option<usize>,
    #[arg(long, default_value = "out.png")]
    out: std::path::PathBuf,
}

/// `--shade`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum ShadeArg {
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
pub enum HitArg {
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

impl ModeArg {
    /// The word of the command line (for messages).
    pub fn name(self) -> &'static str {
        match self {
            ModeArg::Iso => "iso",
            ModeArg::Dvr => "dvr",
        }
    }
}

impl CacheArg {
    /// The word of the command line (for messages).
    pub fn name(self) -> &'static str {
        match self {
            CacheArg::None => "none",
            CacheArg::Perm => "perm",
        }
    }
}

/// Checks the flags into a request, then does its work.
pub fn run(a: RenderArgs) -> Result<(), Failure> {
    match RenderRequest::from_args(a)? {
        RenderRequest::Four(r) => four::run(&r),
        RenderRequest::Three(r) => core::run(&r),
    }
}
