//! `render --gpu-budget`: an isosurface or a volume rendering out of core,
//! with the frame's passes, uploads and memory on one line.

use super::checked::{Look, PagedRequest, ThreeRequest};
use crate::common::Failure;
use boxforge::derive::Derivation;
use boxforge_runtime::gpu::Gpu;
use boxforge_runtime::render::dvr::transfer::{Tf1d, TransferFunction};
use boxforge_runtime::render::dvr::{DvrLook, DvrOptions};
use boxforge_runtime::render::iso::{self as render, Frame, RenderOptions};
use boxforge_runtime::render::paged::{human, PagedDvrRenderer, PagedIsoRenderer, PagedOptions, PagedStats};
use boxforge_runtime::volume::{BrickSource, MappedVolume};

/// The work of a checked `render --gpu-budget`: the source opened, the
/// default ramp (when no --tf) over its samples, one frame in passes.
pub fn run(r: &ThreeRequest, p: &PagedRequest, d: &Derivation, tf: Option<TransferFunction>) -> Result<(), Failure> {
    let f = &r.frame;
    let options = boxforge_runtime::render::paged::PagedOptions {
        iso: f.iso,
        step: f.step,
        brick: r.brick.unwrap_or(boxforge_runtime::volume::BrickShape::DEFAULT_EDGE),
        format: r.format,
        budget: p.budget,
        max_pixels: f.size as u64 * f.size as u64,
        bounds_cache: p.bounds_cache.then(boxforge_runtime::volume::default_cache_dir),
        ..Default::default()
    };
    let camera = RenderOptions {
        width: f.size,
        height: f.size,
        azimuth: f.azimuth,
        elevation: f.elevation,
        perspective: f.perspective,
        frames: 0,
        ..RenderOptions::default()
    };
    let source = open_source(&r.source, &r.filter.lattice)?;
    let what = match &r.look {
        Look::Iso(_) => Paged::Iso(camera),
        Look::Dvr(look) => {
            let tf = match tf {
                Some(tf) => tf,
                None => {
                    // No --tf: the default ramp over the samples' range (one pass over the source).
                    let (lo, hi) = source.sample_range().map_err(|e| Failure(e.to_string()))?;
                    super::look::default_ramp(lo, hi)
                }
            };
            let o = super::look::dvr_options(r, look);
            let look = DvrLook::from(&o);
            Paged::Dvr(tf.table(), look, o)
        }
    };
    // Before the device starts its threads (see the function's doc).
    boxforge_runtime::memory::one_heap_arena();
    let gpu = Gpu::new(f.adapter.as_deref()).map_err(|e| Failure(e.to_string()))?;
    crate::request::check_image_limits(f.size, &gpu.limits())?;
    render(&gpu, d, source.as_ref(), options, what, &f.out, p.stats_json)
}

/// The samples `--volume` names, for out-of-core rendering: `ml:N` built in
/// memory, an OME-Zarr level read chunk by chunk, a file mapped and read
/// brick by brick (a `.nii.gz` decompressed once into the cache folder,
/// with progress).
fn open_source(
    source: &super::checked::Source,
    lattice: &boxforge::spec::lattice::Lattice,
) -> Result<Box<dyn BrickSource>, Failure> {
    let (volume, raw) = (source.volume.as_str(), source.raw.as_deref());
    if let Some(s) = source.zarr {
        use boxforge_runtime::volume::zarr::{OmeZarr, ZarrVolume};
        let fail = |e: &dyn std::fmt::Display| Failure(e.to_string());
        let image = OmeZarr::open(std::path::Path::new(volume)).map_err(|e| fail(&e))?;
        return Ok(Box::new(ZarrVolume::new(&image, s, lattice).map_err(|e| fail(&e))?));
    }
    if volume.starts_with("ml:") {
        let v = boxforge_runtime::scene::load(volume, None, lattice, boxforge_runtime::scene::Conversion::Subset)
            .map_err(|e| Failure(e.to_string()))?;
        return Ok(Box::new(v));
    }
    let cache = boxforge_runtime::volume::default_cache_dir();
    let last = std::cell::Cell::new(u64::MAX);
    let progress = |done: u64, total: u64| {
        let pct = done * 100 / total.max(1);
        if pct / 10 != last.get() / 10 {
            last.set(pct);
            eprintln!("decompressing {volume} into {}: {pct}%", cache.display());
        }
    };
    let m = MappedVolume::open(std::path::Path::new(volume), raw, lattice, &cache, &progress)
        .map_err(|e| Failure(e.to_string()))?;
    Ok(Box::new(m))
}

/// What `render --gpu-budget` draws.
enum Paged {
    /// An isosurface (the camera and image size).
    Iso(RenderOptions),
    /// A volume rendering: the transfer function, the look and the frame.
    Dvr(Tf1d, DvrLook, DvrOptions),
}

/// Either out-of-core renderer, built (one per command: its size is no matter).
#[allow(clippy::large_enum_variant)]
enum Renderer {
    Iso(PagedIsoRenderer, RenderOptions),
    Dvr(PagedDvrRenderer, DvrOptions),
}

impl Renderer {
    fn frame(&mut self, source: &dyn BrickSource) -> Result<(Frame, PagedStats), Failure> {
        match self {
            Renderer::Iso(r, o) => r.render(source, o),
            Renderer::Dvr(r, o) => r.render(source, o),
        }
        .map_err(|e| Failure(e.to_string()))
    }

    fn bounds_cached(&self) -> bool {
        match self {
            Renderer::Iso(r, _) => r.bounds_cached(),
            Renderer::Dvr(r, _) => r.bounds_cached(),
        }
    }
}

/// Preprocesses `source` brick row by brick row (a progress line on
/// stderr), renders one frame in passes and writes it to `out`.
fn render(
    gpu: &Gpu,
    d: &Derivation,
    source: &dyn BrickSource,
    options: PagedOptions,
    what: Paged,
    out: &std::path::Path,
    stats_json: bool,
) -> Result<(), Failure> {
    let started = std::time::Instant::now();
    let last = std::cell::Cell::new(0usize);
    let progress = |done: usize, total: usize| {
        let pct = done * 100 / total.max(1);
        if pct / 10 != last.get() / 10 || done == total {
            last.set(pct);
            eprintln!("bounding blocks: {done}/{total} brick rows ({pct}%)");
        }
    };
    let budget = options.budget;
    let failed = |e: boxforge_runtime::render::RenderError| Failure(e.to_string());
    let (mut r, holding) = match what {
        Paged::Iso(o) => {
            (Renderer::Iso(PagedIsoRenderer::new(gpu, d, source, options, &progress).map_err(failed)?, o), "surface's")
        }
        Paged::Dvr(table, look, o) => (
            Renderer::Dvr(PagedDvrRenderer::new(gpu, d, source, table, look, options, &progress).map_err(failed)?, o),
            "visible",
        ),
    };
    let preprocess_ms = started.elapsed().as_secs_f64() * 1e3;
    if r.bounds_cached() {
        eprintln!(
            "block bounds read from the cache in {} (--no-bounds-cache computes them again)",
            boxforge_runtime::volume::default_cache_dir().display()
        );
    }

    let (frame, stats) = r.frame(source)?;
    let host = boxforge_runtime::memory::peak_resident_bytes().map_or("unknown".into(), human);
    render::write_png(out, frame.width, frame.height, &frame.rgba)
        .map_err(|e| Failure(format!("cannot write {}: {e}", out.display())))?;
    eprintln!(
        "{}: {}x{} in {:.1} ms out of core: {} passes, {} bricks uploaded ({} evicted) into {} slots; {} of {} bricks hold {holding} blocks; device {} of the {} budget; peak host memory (VmHWM) {host}",
        out.display(),
        frame.width,
        frame.height,
        stats.ms,
        stats.passes,
        stats.uploads,
        stats.evictions,
        stats.slots,
        stats.occupied_bricks,
        stats.bricks,
        human(stats.device_bytes),
        human(budget),
    );
    if stats_json {
        let (_, warm) = r.frame(source)?;
        let json = serde_json::json!({
            "preprocess_ms": preprocess_ms,
            "bounds_cached": r.bounds_cached(),
            "first": stats,
            "warm": warm,
            "host_peak_bytes": boxforge_runtime::memory::peak_resident_bytes(),
            "source_resident_bytes": source.resident_bytes(),
        });
        outln!("{json}");
    }
    Ok(())
}
