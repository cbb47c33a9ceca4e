//! `render --gpu-budget`: an isosurface out of core, with the frame's passes,
//! uploads and memory on one line.

use crate::common::Failure;
use boxforge::derive::Derivation;
use boxforge_runtime::gpu::Gpu;
use boxforge_runtime::render::iso::{self as render, RenderOptions};
use boxforge_runtime::render::paged::{human, PagedIsoRenderer, PagedOptions};
use boxforge_runtime::volume::BrickSource;

/// Preprocesses `source` brick row by brick row (a progress line on
/// stderr), renders one frame in passes and writes it to `out`.
pub fn render(
    gpu: &Gpu,
    d: &Derivation,
    source: &dyn BrickSource,
    options: PagedOptions,
    camera: &RenderOptions,
    out: &std::path::Path,
) -> Result<(), Failure> {
    let last = std::cell::Cell::new(0usize);
    let progress = |done: usize, total: usize| {
        let pct = done * 100 / total.max(1);
        if pct / 10 != last.get() / 10 || done == total {
            last.set(pct);
            eprintln!("bounding blocks: {done}/{total} brick rows ({pct}%)");
        }
    };
    let mut r = PagedIsoRenderer::new(gpu, d, source, options, &progress).map_err(|e| Failure(e.to_string()))?;
    let (frame, stats) = r.render(source, camera).map_err(|e| Failure(e.to_string()))?;
    render::write_png(out, frame.width, frame.height, &frame.rgba)
        .map_err(|e| Failure(format!("cannot write {}: {e}", out.display())))?;
    eprintln!(
        "{}: {}x{} in {:.1} ms out of core: {} passes, {} bricks uploaded ({} evicted) into {} slots; {} of {} bricks hold the surface's blocks; device {} of the {} budget",
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
        human(options.budget),
    );
    Ok(())
}
