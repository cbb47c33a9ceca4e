//! `boxforge bench --perm` (issue #14, part 3): for bcc_linear, bcc7,
//! bcc12 and cc_tricubic, DVR ms/frame with the PERM cache
//! ([`crate::render::perm`]) against direct evaluation (per-round ratios, the two
//! interleaved), the cache's preprocessing time and memory (bytes per part,
//! against the paper's equation 6 applied to the counts), and the RMS of its
//! image against the direct one, for N = 3, 5, 10 and unequal (N, M) =
//! (5, 3), and (5, 3) with and without opaque-boundary peeling under an opaque transfer function. On the MNI head (resampled on each filter's lattice after a
//! box-average downsampling by [`HEAD_DOWNSAMPLE`] per axis, so that every
//! filter's cache at N = 10 stays under the 2 GiB cache limit: the BCC
//! filters' at 2 mm would need 6.5 GB) with the `mni-tissue` preset, or
//! Marschner-Lobb 24^3 with `marschner-lobb` when the run has no head
//! (smoke). Its own section of BENCHMARKS.md, which the full bench keeps.

use super::stats::{median, round_order, Ratio};
use super::BenchError;
use crate::gpu::Gpu;
use crate::render::dvr::transfer::TransferFunction;
use crate::render::dvr::{rms, DvrOptions, DvrScene};
use crate::render::perm::{formula, Memory, PermCache, Quant};
use crate::volume::{LatticeVolume, Volume};
use boxforge::derive::Derivation;
use boxforge::emit::Layout;
use serde::Serialize;
use std::fmt::Write as _;

pub const SECTION_START: &str = "<!-- perm-bench:start -->";
pub const SECTION_END: &str = "<!-- perm-bench:end -->";

/// The filters of the issue.
pub const FILTERS: [&str; 4] = ["bcc_linear", "bcc7", "bcc12", "cc_tricubic"];
/// (N, M): density and gradient positions per cell axis.
pub const QUANTS: [(u32, u32); 4] = [(3, 3), (5, 5), (10, 10), (5, 3)];
/// The (N, M) measured once more with opaque-boundary peeling.
pub const PEELED: (u32, u32) = (5, 3);
/// Segment length of the timed frames (cells).
pub const STEP: f32 = 0.5;
/// Box-average factor per axis applied to the MNI head before resampling.
pub const HEAD_DOWNSAMPLE: usize = 4;

/// One (filter, N, M): the cache against direct evaluation on one volume.
#[derive(Clone, Debug, Serialize)]
pub struct PermRow {
    pub filter: String,
    /// "mni_down4" or "ml".
    pub volume: String,
    /// The transfer function's name.
    pub tf: String,
    pub samples: usize,
    pub density: u32,
    pub gradient: u32,
    /// Opaque-boundary peeling on, and the candidate cells it dropped.
    pub peel: bool,
    pub peeled: u64,
    /// Cells of the volume (S) and candidate cells (N_cc).
    pub cells: u64,
    pub candidates: u64,
    pub preprocess_ms: f64,
    /// Bytes allocated, per part.
    pub memory: Memory,
    /// The paper's equation 6 applied to the same counts (bytes).
    pub formula_bytes: u64,
    /// Medians over the rounds (ms/frame).
    pub direct_ms: f64,
    pub perm_ms: f64,
    /// direct ÷ PERM time, per round: above 1 the cache is faster.
    pub speedup: Ratio,
    /// RMS of the PERM image against the direct one (of 255).
    pub rms: f64,
}

/// A cache that could not be built (the reason, e.g. over the limit).
#[derive(Clone, Debug, Serialize)]
pub struct Refused {
    pub filter: String,
    pub density: u32,
    pub gradient: u32,
    pub peel: bool,
    pub reason: String,
}

/// `boxforge bench --perm`.
#[derive(Clone, Debug, Serialize)]
pub struct PermReport {
    pub adapter: String,
    pub size: u32,
    pub rounds: usize,
    pub rows: Vec<PermRow>,
    pub refused: Vec<Refused>,
}

/// Every filter of [`FILTERS`] at every (N, M) of [`QUANTS`] on `head`
/// (downsampled by [`HEAD_DOWNSAMPLE`]) or, without one, Marschner-Lobb 24^3;
/// frames of `size`^2, `rounds` interleaved rounds.
pub fn run(
    gpu: &Gpu,
    head: Option<&Volume>,
    size: u32,
    rounds: usize,
    progress: &dyn Fn(&str),
) -> Result<PermReport, BenchError> {
    let small = head.map(|h| h.downsample(HEAD_DOWNSAMPLE));
    let mut report = PermReport { adapter: gpu.describe(), size, rounds: rounds.max(1), rows: vec![], refused: vec![] };
    for name in FILTERS {
        let d = Derivation::new(&boxforge::spec::resolve(name)?)?;
        let (vol, tfs, what, view) = match &small {
            Some(h) => {
                let v = crate::scene::from_cartesian(h, &d.filter.lattice, crate::scene::Conversion::Resample)?;
                (v, ["mni-tissue", "mni-opaque"], format!("mni_down{HEAD_DOWNSAMPLE}"), (200.0, 15.0))
            }
            None => {
                let v = LatticeVolume::marschner_lobb(&d.filter.lattice, [24, 24, 24])?;
                (v, ["marschner-lobb", "marschner-lobb"], "ml".to_string(), (30.0, 25.0))
            }
        };
        // Every N on the first transfer function; peeling, with and without,
        // on the second (opaque: what peeling is for).
        let every: Vec<((u32, u32), bool)> = QUANTS.iter().map(|&q| (q, false)).collect();
        let peeling = [(PEELED, false), (PEELED, true)];
        for (tf, configs) in [(tfs[0], &every[..]), (tfs[1], &peeling[..])] {
            let tf = TransferFunction::preset(tf);
            measure_filter(gpu, &d, &vol, &tf, configs, (&what, view, size), report.rounds, progress, &mut report)?;
        }
    }
    Ok(report)
}

/// The rows of one filter on one volume, one per (N, M) of [`QUANTS`]: the
/// direct frames and the PERM frames interleaved in the same rounds.
#[allow(clippy::too_many_arguments)]
fn measure_filter(
    gpu: &Gpu,
    d: &Derivation,
    vol: &LatticeVolume,
    tf: &TransferFunction,
    configs: &[((u32, u32), bool)],
    (what, view, size): (&str, (f32, f32), u32),
    rounds: usize,
    progress: &dyn Fn(&str),
    report: &mut PermReport,
) -> Result<(), BenchError> {
    let name = &d.filter.name;
    let scene = DvrScene::new(gpu, d, vol, Layout::Embedded, 4)?;
    let o = DvrOptions {
        width: size,
        height: size,
        azimuth: view.0,
        elevation: view.1,
        step: STEP,
        frames: 1,
        ..DvrOptions::default()
    };
    let table = tf.table();
    let pi = table.preintegrate(STEP as f64);
    let reference = scene.render_tables(&table, Some(&pi), &DvrOptions { frames: 0, ..o.clone() })?;
    for &((n, m), peel) in configs {
        let quant = Quant { density: n, gradient: m };
        let peeling = if peel { ", peeled" } else { "" };
        progress(&format!(
            "{name} PERM {what} ({} samples, {}) N={n} M={m}{peeling}: preprocessing, then {rounds} rounds at {size}^2",
            vol.samples(),
            tf.name
        ));
        let cache = match PermCache::build_peeled(&scene, &table, quant, STEP, true, peel.then_some(o.termination)) {
            Ok(c) => c,
            Err(x) => {
                report.refused.push(Refused {
                    filter: name.clone(),
                    density: n,
                    gradient: m,
                    peel,
                    reason: x.to_string(),
                });
                continue;
            }
        };
        let (mut direct, mut perm) = (vec![], vec![]);
        for r in 0..rounds.max(1) {
            for k in round_order(2, r) {
                if k == 0 {
                    direct.push(scene.render_tables(&table, Some(&pi), &o)?.ms_per_frame);
                } else {
                    perm.push(cache.render(&scene, &table, Some(&pi), &o)?.ms_per_frame);
                }
            }
        }
        let image = cache.render(&scene, &table, Some(&pi), &DvrOptions { frames: 0, ..o.clone() })?;
        let c = cache.counts;
        report.rows.push(PermRow {
            filter: name.clone(),
            volume: what.to_string(),
            tf: tf.name.clone(),
            samples: vol.samples(),
            density: n,
            gradient: m,
            peel,
            peeled: cache.peeled,
            cells: c.cells,
            candidates: c.candidates,
            preprocess_ms: cache.preprocess_ms,
            memory: cache.memory,
            formula_bytes: formula(&c).total(),
            direct_ms: median(&direct),
            perm_ms: median(&perm),
            speedup: Ratio::of_rates(&direct, &perm),
            rms: rms(&image.rgba, &reference.rgba),
        });
    }
    Ok(())
}

/// Where the cache wins: the (filter, N, M) whose speed-up is above 1 in
/// every round, as one sentence.
pub fn verdict(rows: &[PermRow]) -> String {
    if rows.is_empty() {
        return "No PERM cache was measured.".into();
    }
    let label = |r: &PermRow| {
        let peel = if r.peel { " peeled" } else { "" };
        let tf = if r.tf != rows[0].tf { format!(" with {}", r.tf) } else { String::new() };
        format!("{} N={} M={}{peel}{tf} ({:.2}x)", r.filter, r.density, r.gradient, r.speedup.median)
    };
    let wins: Vec<String> = rows.iter().filter(|r| r.speedup.min > 1.0).map(label).collect();
    let losses: Vec<String> = rows.iter().filter(|r| r.speedup.max < 1.0).map(label).collect();
    let ties: Vec<String> = rows.iter().filter(|r| r.speedup.tie).map(label).collect();
    format!(
        "On this adapter the PERM cache wins (faster than direct evaluation in every round) for {}; it loses (slower in every round) for {}; {}.",
        if wins.is_empty() { "no filter and N".into() } else { wins.join(", ") },
        if losses.is_empty() { "none".into() } else { losses.join(", ") },
        if ties.is_empty() { "no ties".into() } else { format!("the rounds disagree (a tie) for {}", ties.join(", ")) }
    )
}

/// The markdown section (between [`SECTION_START`] and [`SECTION_END`]).
pub fn markdown(r: &PermReport, command: &str) -> String {
    let mut s = String::new();
    let _ = writeln!(s, "{SECTION_START}\n## PERM (Lim and Shin)\n");
    let what = r.rows.first().map_or("", |x| x.volume.as_str());
    let data = if what.starts_with("mni") {
        format!("the MNI head box-averaged by {HEAD_DOWNSAMPLE} per axis (4 mm) and resampled on each filter's lattice, every N with the mni-tissue preset, and (N, M) = (5, 3) with and without peeling with mni-opaque (every tissue opaque, the surface-like rendering peeling is for)")
    } else {
        "Marschner-Lobb 24^3 with its preset".to_string()
    };
    let _ = writeln!(
        s,
        "Written by `{command}` on {}. `render --mode dvr --cache perm --qc N --qc-grad M`: density and analytic gradient precomputed on the device at N^3 and M^3 positions of every cell the transfer function shows (dilated by one cell for pre-integration), looked up by the ray caster (nearest position). Data: {data}; {}^2 frames, step {STEP}, pre-integrated, TF skipping; direct and PERM frames interleaved in {} round(s) (speed-up: direct ÷ PERM time per round, median [min..max], a tie when the range spans 1). Memory: bytes allocated per part (index volume + summed-area table / densities / gradient magnitudes + signs), against the paper's equation 6 with b_iv = 2, b_db = 2, 3 gradient bytes and a sign byte, plus the 4-byte summed-area entry per row. Peeled: `--peel`, opaque-boundary peeling (runtime/src/perm.rs, `peel`), which drops the candidate cells no ray from outside reaches before it terminates at opacity 0.99; the image is the unpeeled cache's.\n",
        r.adapter, r.size, r.rounds
    );
    let _ = writeln!(s, "| filter | transfer function | N | M | peeled | samples | candidate cells | preprocessing | memory: index + SAT / densities / gradients + signs | memory vs formula | direct ms/frame | PERM ms/frame | speed-up | tie? | RMS vs direct |\n|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|");
    for x in &r.rows {
        let m = &x.memory;
        let _ = writeln!(
            s,
            "| {} | {} | {} | {} | {} | {} | {} of {} | {:.0} ms | {} + {} / {} / {} + {} = {} bytes | {:+.3}% | {:.1} | {:.1} | {:.2} [{:.2}..{:.2}] | {} | {:.2}/255 |",
            x.filter,
            x.tf,
            x.density,
            x.gradient,
            if x.peel { format!("{} cells", x.peeled) } else { "no".into() },
            x.samples,
            x.candidates,
            x.cells,
            x.preprocess_ms,
            m.index_volume,
            m.summed_area,
            m.density,
            m.gradient,
            m.sign,
            m.total(),
            (m.total() as f64 / x.formula_bytes as f64 - 1.0) * 100.0,
            x.direct_ms,
            x.perm_ms,
            x.speedup.median,
            x.speedup.min,
            x.speedup.max,
            if x.speedup.tie { "tie" } else { "" },
            x.rms
        );
    }
    for f in &r.refused {
        let peel = if f.peel { " peeled" } else { "" };
        let _ = writeln!(s, "\nNot built: {} N={} M={}{peel}: {}", f.filter, f.density, f.gradient, f.reason);
    }
    let _ = writeln!(s, "\n{}\n{SECTION_END}", verdict(&r.rows));
    s
}

/// `file` with this section replaced (or appended).
pub fn splice(file: &str, section: &str) -> String {
    super::derive::splice_between(file, section, SECTION_START, SECTION_END)
}

/// This section of `file`, if it has one (kept when the GPU bench rewrites the file).
pub fn existing_section(file: &str) -> Option<&str> {
    super::derive::section_between(file, SECTION_START, SECTION_END)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn downsampling_averages_blocks() {
        let v = Volume::new([3, 2, 1], vec![1.0, 3.0, 10.0, 5.0, 7.0, 20.0]).unwrap();
        let s = v.downsample(2);
        assert_eq!(s.dims, [2, 1, 1]);
        assert_eq!(s.data, vec![4.0, 15.0]);
    }

    fn row(f: &str, n: u32, min: f64, max: f64) -> PermRow {
        PermRow {
            filter: f.into(),
            volume: "ml".into(),
            tf: "t".into(),
            samples: 1,
            density: n,
            gradient: n,
            peel: false,
            peeled: 0,
            cells: 1,
            candidates: 1,
            preprocess_ms: 1.0,
            memory: Memory { index_volume: 2, summed_area: 4, density: 2, gradient: 3, sign: 1 },
            formula_bytes: 12,
            direct_ms: 1.0,
            perm_ms: 1.0,
            speedup: Ratio { median: (min + max) / 2.0, min, max, rounds: 3, tie: min <= 1.0 && max >= 1.0 },
            rms: 0.5,
        }
    }

    #[test]
    fn the_verdict_names_wins_losses_and_ties() {
        let v = verdict(&[row("bcc12", 5, 1.5, 2.5), row("bcc_linear", 10, 0.5, 0.7), row("bcc7", 3, 0.9, 1.1)]);
        assert!(v.contains("wins") && v.contains("for bcc12 N=5 M=5 (2.00x)"), "{v}");
        assert!(v.contains("loses (slower in every round) for bcc_linear N=10 M=10 (0.60x)"), "{v}");
        assert!(v.contains("a tie) for bcc7 N=3 M=3"), "{v}");
        // Flipped: the loss becomes a win.
        let v = verdict(&[row("bcc_linear", 10, 1.2, 1.4)]);
        assert!(
            v.contains("wins (faster than direct evaluation in every round) for bcc_linear")
                && v.contains("loses (slower in every round) for none"),
            "{v}"
        );
    }

    #[test]
    fn the_section_splices_into_a_file_and_is_found_again() {
        let r = PermReport {
            adapter: "a".into(),
            size: 8,
            rounds: 1,
            rows: vec![row("bcc7", 5, 1.1, 1.2)],
            refused: vec![],
        };
        let md = markdown(&r, "boxforge bench --perm");
        assert!(md.contains("| bcc7 | t | 5 | 5 | no |") && md.contains("+0.000%"), "{md}");
        let file = splice("# Benchmarks\n\nbody\n", &md);
        assert!(file.starts_with("# Benchmarks") && file.contains(SECTION_END));
        assert_eq!(existing_section(&file).map(str::trim), Some(md.trim()));
        let again = splice(&file, &md);
        assert_eq!(again.matches(SECTION_START).count(), 1);
    }
}
