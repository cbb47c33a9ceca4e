//! Volumes larger than one texture (`boxforge bench --volumes`): in core,
//! the bricked layout against the embedded one and compact sample formats
//! against f32 (ms/frame of the same isosurface, interleaved rounds, one
//! run); out of core, frames of a generated volume on disk at device
//! budgets (each configuration in its own process, so its peak host memory
//! is its own), against a tiny volume's run for the fixed overhead.

use crate::gpu::Gpu;
use crate::render::iso::RenderOptions;
use crate::render::RenderError;
use crate::render::{IsoOptions, IsoRenderer};
use crate::volume::{BrickShape, DeviceVolume, LatticeVolume, SampleFormat, VolumeOptions};
use boxforge::derive::Derivation;
use boxforge::emit::Layout;
use serde::Serialize;
use std::fmt::Write as _;
use std::io::Write as _;

/// Marks the section in BENCHMARKS.md.
pub const SECTION_START: &str = "<!-- volumes-bench:start -->";
/// Marks the end of the section.
pub const SECTION_END: &str = "<!-- volumes-bench:end -->";

/// One in-core configuration's median frame time.
#[derive(Clone, Debug, Serialize)]
pub struct InCoreRow {
    pub filter: String,
    pub layout: String,
    pub format: String,
    pub ms: f64,
    /// The fastest and slowest round (ms/frame).
    pub range: [f64; 2],
    /// Device bytes of the samples (bricked: pool with halos and page table).
    pub bytes: usize,
}

/// One out-of-core configuration (a child process's `render --stats-json`).
#[derive(Clone, Debug, Serialize)]
pub struct OutOfCoreRow {
    pub filter: String,
    pub volume: String,
    pub format: String,
    pub budget: u64,
    /// The child's JSON: first and warm frames' statistics, preprocessing
    /// time, peak host memory.
    pub stats: serde_json::Value,
    /// Peak host memory of the same command on a tiny volume (the fixed
    /// overhead: driver, compiler, buffers).
    pub baseline_host_bytes: Option<u64>,
}

/// What `bench --volumes` measured.
#[derive(Clone, Debug, Serialize)]
pub struct VolumesReport {
    pub adapter: String,
    pub in_core_volume: String,
    pub size: u32,
    pub rounds: usize,
    pub in_core: Vec<InCoreRow>,
    pub out_of_core: Vec<OutOfCoreRow>,
}

/// ms/frame of `filter`'s isosurface on Marschner-Lobb (`edge`^3 box) in
/// four stores: embedded and bricked, f32 and u8, rendered in interleaved
/// rounds after one warm-up frame each (medians).
pub fn in_core(
    gpu: &Gpu,
    filter: &str,
    edge: usize,
    size: u32,
    rounds: usize,
    progress: &dyn Fn(&str),
) -> Result<Vec<InCoreRow>, RenderError> {
    let d = Derivation::new(&boxforge::spec::catalog::get(filter)?)?;
    let vol = LatticeVolume::marschner_lobb(&d.filter.lattice, [edge; 3])?;
    let bricks = BrickShape::for_filter(&d);
    let configs = [
        (Layout::Embedded, SampleFormat::F32),
        (Layout::Bricked, SampleFormat::F32),
        (Layout::Embedded, SampleFormat::U8),
        (Layout::Bricked, SampleFormat::U8),
    ];
    let o = RenderOptions { width: size, height: size, frames: 1, ..RenderOptions::default() };
    let mut renderers = Vec::new();
    for (layout, format) in configs {
        progress(&format!("{filter}: {} {}", layout.name(), format.name()));
        let dv = DeviceVolume::with_options(gpu, &vol, layout, &VolumeOptions { format, bricks, max_pool_edge: None })?;
        let options = IsoOptions { iso: o.iso, step: o.step, block: o.block, skip: true, ..IsoOptions::default() };
        let mut r = IsoRenderer::new(gpu, &d, &dv, options)?;
        r.timed_frames(&o)?;
        renderers.push((layout, format, dv.bytes, r, Vec::new()));
    }
    for round in 0..rounds {
        progress(&format!("{filter}: round {} of {rounds}", round + 1));
        for (_, _, _, r, times) in renderers.iter_mut() {
            times.push(r.timed_frames(&o)?.0.ms_per_frame);
        }
    }
    Ok(renderers
        .into_iter()
        .map(|(layout, format, bytes, _, mut times)| {
            times.sort_by(f64::total_cmp);
            InCoreRow {
                filter: filter.into(),
                layout: layout.name().into(),
                format: format.name().into(),
                ms: times[times.len() / 2],
                range: [times[0], times[times.len() - 1]],
                bytes,
            }
        })
        .collect())
}

/// Writes Marschner-Lobb sampled on a `dims` grid as u8 (255 v, rounded)
/// to `path`, one z-slice at a time (host memory: one slice), unless a file
/// of that size is already there. Returns whether it wrote.
pub fn write_ml_u8(path: &std::path::Path, dims: [usize; 3], progress: &dyn Fn(usize, usize)) -> std::io::Result<bool> {
    let bytes = (dims[0] * dims[1] * dims[2]) as u64;
    if std::fs::metadata(path).map(|m| m.len() == bytes).unwrap_or(false) {
        return Ok(false);
    }
    if let Some(dir) = path.parent() {
        std::fs::create_dir_all(dir)?;
    }
    let tmp = path.with_extension("partial");
    let mut f = std::io::BufWriter::new(std::fs::File::create(&tmp)?);
    let mut slice = vec![0u8; dims[0] * dims[1]];
    for z in 0..dims[2] {
        for y in 0..dims[1] {
            for x in 0..dims[0] {
                let p = crate::volume::ml_position(dims, [x as f64, y as f64, z as f64]);
                slice[x + dims[0] * y] = (crate::volume::marschner_lobb(p) * 255.0).round().clamp(0.0, 255.0) as u8;
            }
        }
        f.write_all(&slice)?;
        progress(z + 1, dims[2]);
    }
    f.flush()?;
    drop(f);
    std::fs::rename(&tmp, path)?;
    Ok(true)
}

fn mib(b: u64) -> String {
    format!("{:.0} MiB", b as f64 / (1024.0 * 1024.0))
}

fn num(v: &serde_json::Value, path: &[&str]) -> f64 {
    let mut x = v;
    for p in path {
        x = &x[*p];
    }
    x.as_f64().unwrap_or(f64::NAN)
}

/// Per filter, u8 embedded against f32 embedded: "met" (median ratio >=
/// 1), "a tie" (below, but the rounds' ranges overlap) or "missed".
pub fn u8_verdicts(rows: &[InCoreRow]) -> Vec<String> {
    let mut out = Vec::new();
    for f32_row in rows.iter().filter(|r| r.layout == "embedded" && r.format == "f32") {
        let Some(u8_row) =
            rows.iter().find(|r| r.filter == f32_row.filter && r.layout == "embedded" && r.format == "u8")
        else {
            continue;
        };
        let ratio = f32_row.ms / u8_row.ms;
        let verdict = if ratio >= 1.0 {
            "met"
        } else if u8_row.range[0] <= f32_row.range[1] {
            "a tie"
        } else {
            "missed"
        };
        out.push(format!("{} {ratio:.2}x, {verdict}", f32_row.filter));
    }
    out
}

/// The section as Markdown.
pub fn markdown(r: &VolumesReport, command: &str) -> String {
    let mut s = String::new();
    let _ = writeln!(s, "{SECTION_START}\n## Volumes larger than one texture\n");
    let _ = writeln!(s, "Generated by `{command}` on {}.\n", r.adapter);
    let _ = writeln!(
        s,
        "**In core** ({}, {}x{} isosurface, iso 0.5, median of {} interleaved rounds after a warm-up frame each): the bricked layout (bricks of {} texels with the filter's halo, one page-table lookup per evaluation) and u8 samples (four to an R32Uint texel along x, shifted out and converted per fetch, the map applied once per evaluation) against the embedded f32 texture. Ratio: embedded f32 ms / this row's ms (> 1: faster); range: the fastest and slowest round.\n",
        r.in_core_volume, r.size, r.size, r.rounds, BrickShape::DEFAULT_EDGE
    );
    let _ = writeln!(s, "| filter | layout | format | ms/frame | range | ratio | device bytes |");
    let _ = writeln!(s, "|---|---|---|---:|---|---:|---:|");
    for row in &r.in_core {
        let base = r.in_core.iter().find(|b| b.filter == row.filter && b.layout == "embedded" && b.format == "f32");
        let ratio = base.map_or(f64::NAN, |b| b.ms / row.ms);
        let _ = writeln!(
            s,
            "| {} | {} | {} | {:.2} | {:.2}..{:.2} | {:.2}x | {} |",
            row.filter, row.layout, row.format, row.ms, row.range[0], row.range[1], ratio, row.bytes
        );
    }
    let _ = writeln!(s);
    let verdicts = u8_verdicts(&r.in_core);
    if !verdicts.is_empty() {
        let _ = writeln!(
            s,
            "Target u8 >= 1.0x f32 (embedded; a tie, overlapping ranges, counts): {}.\n",
            verdicts.join(", ")
        );
    }
    if r.adapter.contains("llvmpipe") {
        let _ = writeln!(
            s,
            "On llvmpipe a texel fetch is a software gather: Mesa's `lp_build_gather` (gallivm/lp_bld_gather.c) uses AVX2's vector gather only for 32-bit texels that need no expansion, and loads 8-bit ones lane by lane. That is why u8 samples are four to an R32Uint texel: stored as R8Unorm, one a texel, they ran at 0.86x (bcc7) and 0.84x (cc_tricubic) of f32 here (the report of 2026-12-04).\n"
        );
    }
    if !r.out_of_core.is_empty() {
        let _ = writeln!(
            s,
            "**Out of core** (`render --gpu-budget`, each row its own process reading the u8 file through a memory map; {}x{} frames; isosurfaces at 127.5, and rows marked DVR volume renderings under the default ramp transfer function, `--mode dvr`): the first frame starts with an empty pool, the warm frame follows it. Peak host memory is the process's VmHWM; on lavapipe device memory is host memory, so it holds the pool too (on a GPU it does not). Fixed overhead: VmHWM of the same command on `ml:8` (driver, shader compiler, buffers). The ray casters' parameter blocks and the kernels' job are storage buffers on lavapipe (`runtime/src/gpu/params.rs`): as uniform blocks, lavapipe compiled and kept a shader variant at each dispatch, about 3 MB a pass for bcc7 and 1.5 MB a slab of the bounds. `render --gpu-budget` keeps one heap arena (`memory::one_heap_arena`): with an arena per thread, the same run's peak varied by 20 MB. On a GPU the pool is device memory and the host stays near the overhead.\n",
            r.size, r.size
        );
        let _ = writeln!(s, "| filter | volume | budget | bounds (s) | first frame ms (passes, bricks uploaded) | warm frame ms (passes, uploads) | slots | bricks holding surface (DVR: visible blocks) / all | device | peak host | fixed overhead | host - overhead vs budget |");
        let _ = writeln!(s, "|---|---|---:|---:|---|---|---:|---|---:|---:|---:|---|");
        for row in &r.out_of_core {
            let st = &row.stats;
            let host = st["host_peak_bytes"].as_u64().unwrap_or(0);
            let base = row.baseline_host_bytes.unwrap_or(0);
            let over = host.saturating_sub(base);
            let _ = writeln!(
                s,
                "| {} | {} | {} | {:.1} | {:.0} ({}, {}) | {:.0} ({}, {}) | {} | {} / {} | {} | {} | {} | {} {} {} |",
                row.filter,
                row.volume,
                mib(row.budget),
                num(st, &["preprocess_ms"]) / 1e3,
                num(st, &["first", "ms"]),
                st["first"]["passes"],
                st["first"]["uploads"],
                num(st, &["warm", "ms"]),
                st["warm"]["passes"],
                st["warm"]["uploads"],
                st["first"]["slots"],
                st["first"]["occupied_bricks"],
                st["first"]["bricks"],
                mib(st["first"]["device_bytes"].as_u64().unwrap_or(0)),
                mib(host),
                mib(base),
                mib(over),
                if over <= row.budget { "<=" } else { ">" },
                mib(row.budget),
            );
        }
        let _ = writeln!(s);
        let _ = writeln!(
            s,
            "**Past one device, on paper** (sort-last, as IceT composites): cut the brick grid into N boxes, one per GPU (each with the halo bricks of its neighbours, 2h/B of a brick more per face), let each GPU render the rays' segments through its box out of core as above, and composite: for isosurfaces the nearest hit per pixel (colour + f32 depth, 8 bytes a pixel), for DVR the partial images in visibility order. Binary-swap compositing moves about 8 W H bytes per GPU per frame in log2 N rounds, {:.1} MiB at {}x{}, small beside the bricks each GPU uploads. What the single-device rows imply:\n",
            8.0 * f64::from(r.size) * f64::from(r.size) / f64::from(1u32 << 20),
            r.size,
            r.size
        );
        for row in &r.out_of_core {
            let st = &row.stats;
            let uploads = st["first"]["uploads"].as_u64().unwrap_or(0);
            let slots = st["first"]["slots"].as_u64().unwrap_or(1).max(1);
            let device = st["first"]["device_bytes"].as_u64().unwrap_or(0);
            let slot_bytes = device as f64 / slots as f64;
            let working = uploads as f64 * slot_bytes;
            let gpus = (working / (row.budget as f64 * 0.9)).ceil().max(1.0);
            let share = if gpus <= 1.0 {
                "one GPU of this budget holds it resident: more GPUs would only split the bounding".to_string()
            } else {
                format!("{gpus} GPUs of this budget would hold it resident between them (each reading and bounding about 1/{gpus} of the bricks)")
            };
            let _ = writeln!(
                s,
                "- {} on {} at {}: the first frame's working set is {} bricks, about {} of slots; {share}; bounding the blocks took {:.0} s here, which N GPUs would share.",
                row.filter,
                row.volume,
                mib(row.budget),
                uploads,
                mib(working as u64),
                num(st, &["preprocess_ms"]) / 1e3
            );
        }
        let _ = writeln!(s);
    }
    let _ = writeln!(s, "{SECTION_END}");
    s
}

/// `file` with this section replaced (or appended).
pub fn splice(file: &str, section: &str) -> String {
    super::derive::splice_between(file, section, SECTION_START, SECTION_END)
}

/// This section of `file`, if it has one.
pub fn existing_section(file: &str) -> Option<&str> {
    super::derive::section_between(file, SECTION_START, SECTION_END)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The note on llvmpipe's gathers is written for llvmpipe only.
    #[test]
    fn the_gather_note_is_for_llvmpipe_only() {
        let report = |adapter: &str| VolumesReport {
            adapter: adapter.into(),
            in_core_volume: "Marschner-Lobb, 32^3 box".into(),
            size: 64,
            rounds: 1,
            in_core: vec![],
            out_of_core: vec![],
        };
        let cpu = markdown(&report("llvmpipe (LLVM 15.0.6, 256 bits) (Cpu, Vulkan, driver llvmpipe)"), "bench");
        assert!(cpu.contains("lp_build_gather"), "{cpu}");
        let gpu = markdown(&report("NVIDIA H200 (DiscreteGpu, Vulkan)"), "bench");
        assert!(!gpu.contains("lp_build_gather"), "{gpu}");
    }

    #[test]
    fn u8_against_f32_is_met_tied_or_missed_by_median_and_range() {
        let row = |format: &str, ms: f64, range: [f64; 2]| InCoreRow {
            filter: "bcc7".into(),
            layout: "embedded".into(),
            format: format.into(),
            ms,
            range,
            bytes: 0,
        };
        let verdict = |u8_ms: f64, u8_range: [f64; 2]| {
            u8_verdicts(&[row("f32", 100.0, [95.0, 110.0]), row("u8", u8_ms, u8_range)]).join("")
        };
        assert!(verdict(99.0, [97.0, 101.0]).ends_with("met"));
        assert!(verdict(104.0, [100.0, 120.0]).ends_with("a tie"));
        assert!(verdict(120.0, [111.0, 130.0]).ends_with("missed"));
    }
}
