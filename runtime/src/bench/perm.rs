//! PERM rows of `boxforge bench` (issue #14, part 3): for bcc_linear, bcc7,
//! bcc12 and cc_tricubic, DVR ms/frame with the PERM cache
//! ([`crate::perm`]) against direct evaluation (per-round ratios, the two
//! interleaved), the cache's preprocessing time and memory (bytes per part,
//! the paper's equation 6), and the RMS of its image against the direct one,
//! for N = 3, 5, 10 and unequal (N, M) = (5, 3). On the MNI head (resampled
//! on each filter's lattice after a box-average downsampling by
//! [`HEAD_DOWNSAMPLE`] per axis: the full head at N = 10 would need more
//! than the cache's 2 GiB limit, and lavapipe renders it slowly) with the
//! `mni-tissue` preset, or Marschner-Lobb 24^3 with `marschner-lobb` when
//! the run has no head (smoke).

use super::stats::{median, round_order, Ratio};
use super::{BenchOptions, BenchRow};
use crate::dvr::{rms, DvrOptions, DvrScene};
use crate::gpu::Gpu;
use crate::perm::{PermCache, Quant};
use crate::transfer::TransferFunction;
use crate::volume::{LatticeVolume, Volume};
use boxforge::derive::Derivation;
use boxforge::emit::Layout;

/// Prefix of the PERM rows' `kind`.
pub const KIND: &str = "perm";
/// The filters of the issue.
pub const FILTERS: [&str; 4] = ["bcc_linear", "bcc7", "bcc12", "cc_tricubic"];
/// (N, M): density and gradient positions per cell axis.
pub const QUANTS: [(u32, u32); 4] = [(3, 3), (5, 5), (10, 10), (5, 3)];
/// Segment length of the timed frames (cells).
pub const STEP: f32 = 0.5;
/// Box-average factor per axis applied to the MNI head before resampling.
pub const HEAD_DOWNSAMPLE: usize = 2;

/// `v` box-averaged over `f`^3 blocks (a partial last block averages what it has).
pub fn downsample(v: &Volume, f: usize) -> Volume {
    let f = f.max(1);
    let dims = v.dims.map(|n| n.div_ceil(f));
    let mut data = Vec::with_capacity(dims.iter().product());
    for z in 0..dims[2] {
        for y in 0..dims[1] {
            for x in 0..dims[0] {
                let (mut sum, mut n) = (0.0f64, 0usize);
                for k in z * f..((z + 1) * f).min(v.dims[2]) {
                    for j in y * f..((y + 1) * f).min(v.dims[1]) {
                        for i in x * f..((x + 1) * f).min(v.dims[0]) {
                            sum += v.data[i + v.dims[0] * (j + v.dims[1] * k)] as f64;
                            n += 1;
                        }
                    }
                }
                data.push((sum / n as f64) as f32);
            }
        }
    }
    Volume { dims, data }
}

/// The PERM rows at the run's first render size (none without one), for
/// the filters of [`FILTERS`] that the run measures.
pub fn rows(gpu: &Gpu, o: &BenchOptions, rounds: usize, progress: &dyn Fn(&str)) -> Result<Vec<BenchRow>, String> {
    let Some(&size) = o.render_sizes.first() else {
        return Ok(vec![]);
    };
    let head = match &o.mni {
        Some(path) => Some(Volume::load_nifti(std::path::Path::new(path)).map_err(|x| x.to_string())?),
        None => None,
    };
    let mut out = vec![];
    for name in FILTERS.into_iter().filter(|f| o.filters.iter().any(|x| x == f)) {
        let d =
            Derivation::new(&boxforge::spec::resolve(name).map_err(|x| x.to_string())?).map_err(|x| x.to_string())?;
        let (vol, tf, what, view) = match &head {
            Some(h) => {
                let small = downsample(h, HEAD_DOWNSAMPLE);
                let v = crate::scene::from_cartesian(&small, &d.filter.lattice, crate::scene::Conversion::Resample)
                    .map_err(|x| x.to_string())?;
                (v, TransferFunction::preset("mni-tissue"), format!("mni_down{HEAD_DOWNSAMPLE}"), (200.0, 15.0))
            }
            None => {
                let v = LatticeVolume::marschner_lobb(&d.filter.lattice, [24, 24, 24]).map_err(|x| x.to_string())?;
                (v, TransferFunction::preset("marschner-lobb"), "ml".to_string(), (30.0, 25.0))
            }
        };
        out.extend(filter_rows(gpu, &d, &vol, &tf, (&what, view, size), rounds, progress)?);
    }
    Ok(out)
}

/// The rows of one filter on one volume: the direct row, then one per
/// (N, M) of [`QUANTS`] (ms/frame, ratio direct ÷ PERM time, bytes).
pub fn filter_rows(
    gpu: &Gpu,
    d: &Derivation,
    vol: &LatticeVolume,
    tf: &TransferFunction,
    (what, view, size): (&str, (f32, f32), u32),
    rounds: usize,
    progress: &dyn Fn(&str),
) -> Result<Vec<BenchRow>, String> {
    let e = |x: crate::gpu::GpuError| x.to_string();
    let name = &d.filter.name;
    let kind = format!("{KIND}_{what}_{size}");
    progress(&format!("{name} PERM {what} {size}^2 ({} samples, {}): direct", vol.samples(), tf.name));
    let scene = DvrScene::new(gpu, d, vol, Layout::Embedded, 4).map_err(e)?;
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
    let reference = scene.render_tables(&table, Some(&pi), &DvrOptions { frames: 0, ..o.clone() }).map_err(e)?;
    let mut direct_all = vec![];
    let mut rows = vec![];
    for (n, m) in QUANTS {
        let quant = Quant { density: n, gradient: m };
        progress(&format!("{name} PERM {what} {size}^2: N={n} M={m}, preprocessing and {rounds} rounds"));
        let cache = match PermCache::build(&scene, &table, quant, STEP, true) {
            Ok(c) => c,
            Err(x) => {
                let mut row =
                    BenchRow::render(name, &kind, format!("PERM N={n} M={m}: not built: {x}"), 0.0, None, None);
                row.ms_per_frame = None;
                rows.push(row);
                continue;
            }
        };
        let (mut direct, mut perm) = (vec![], vec![]);
        for r in 0..rounds.max(1) {
            for k in round_order(2, r) {
                if k == 0 {
                    direct.push(scene.render_tables(&table, Some(&pi), &o).map_err(e)?.ms_per_frame);
                } else {
                    perm.push(cache.render(&scene, &table, Some(&pi), &o).map_err(e)?.ms_per_frame);
                }
            }
        }
        let image = cache.render(&scene, &table, Some(&pi), &DvrOptions { frames: 0, ..o.clone() }).map_err(e)?;
        let c = cache.counts;
        let mut row = BenchRow::render(
            name,
            &kind,
            format!(
                "PERM N={n} M={m}: {} of {} cells cached, preprocessing {:.0} ms, memory {}, RMS vs direct {:.2}/255",
                c.candidates,
                c.cells,
                cache.preprocess_ms,
                cache.memory.describe(),
                rms(&image.rgba, &reference.rgba)
            ),
            median(&perm),
            Some(Ratio::of_rates(&direct, &perm)),
            Some("direct evaluation ÷ PERM (time)".into()),
        );
        row.bytes = Some(cache.memory.total() as usize);
        rows.push(row);
        direct_all.extend(direct);
    }
    let mut all = vec![BenchRow::render(
        name,
        &kind,
        format!("DVR step {STEP}, direct evaluation"),
        median(&direct_all),
        None,
        None,
    )];
    all.extend(rows);
    Ok(all)
}

/// Where the cache wins: the (filter, N, M) whose ratio direct ÷ PERM is
/// above 1 in every round, as one sentence.
pub fn verdict(rows: &[BenchRow]) -> String {
    let perm: Vec<&BenchRow> = rows.iter().filter(|r| r.kind.starts_with(KIND) && r.ratio.is_some()).collect();
    if perm.is_empty() {
        return "No PERM rows were measured.".into();
    }
    let label = |r: &BenchRow| {
        let q = r.variant.split(':').next().unwrap_or("").trim_start_matches("PERM ");
        format!("{} {q} ({:.2}x)", r.filter, r.ratio.unwrap().median)
    };
    let wins: Vec<String> = perm.iter().filter(|r| r.ratio.unwrap().min > 1.0).map(|r| label(r)).collect();
    let losses: Vec<String> = perm.iter().filter(|r| r.ratio.unwrap().max < 1.0).map(|r| label(r)).collect();
    let ties = perm.len() - wins.len() - losses.len();
    format!(
        "On this adapter the PERM cache wins (faster than direct evaluation in every round) for {}; it loses for {}{}.",
        if wins.is_empty() { "no filter and N".into() } else { wins.join(", ") },
        if losses.is_empty() { "none".into() } else { losses.join(", ") },
        if ties > 0 { format!("; {ties} tie(s)") } else { String::new() }
    )
}

/// The markdown paragraph on the PERM rows of a report (empty without them).
pub fn markdown(rows: &[BenchRow]) -> String {
    let perm: Vec<&BenchRow> = rows.iter().filter(|r| r.kind.starts_with(KIND)).collect();
    if perm.is_empty() {
        return String::new();
    }
    let lines: Vec<String> = perm
        .iter()
        .map(|r| {
            let ms = r.ms_per_frame.map_or("-".into(), |m| format!("{m:.1} ms"));
            let ratio = r.ratio.map_or(String::new(), |x| format!(", direct ÷ PERM {}", x.display()));
            format!("- {} {}: {} ({ms}{ratio})", r.filter, r.kind, r.variant)
        })
        .collect();
    format!(
        "\n### PERM (Lim and Shin)\n\n`render --mode dvr --cache perm --qc N --qc-grad M`: density and gradient precomputed on the device at N^3 and M^3 positions of every cell the transfer function shows (dilated by one cell for pre-integration), looked up by the ray caster; step {STEP}, pre-integrated, TF skipping, ms/frame timed in interleaved rounds against direct evaluation; memory in bytes per part (the paper's equation 6 with 2-byte index and density entries, 3 + 1 gradient bytes).\n\n{}\n\n{}\n",
        lines.join("\n"),
        verdict(rows)
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn downsampling_averages_blocks() {
        let v = Volume::new([3, 2, 1], vec![1.0, 3.0, 10.0, 5.0, 7.0, 20.0]).unwrap();
        let s = downsample(&v, 2);
        assert_eq!(s.dims, [2, 1, 1]);
        assert_eq!(s.data, vec![4.0, 15.0]);
    }

    #[test]
    fn the_verdict_names_wins_and_losses() {
        let row = |f: &str, q: &str, min: f64, max: f64| BenchRow {
            ratio: Some(Ratio { median: (min + max) / 2.0, min, max, rounds: 3, tie: min <= 1.0 && max >= 1.0 }),
            ..BenchRow::render(f, "perm_ml_64", format!("PERM {q}: ..."), 1.0, None, None)
        };
        let v = verdict(&[
            row("bcc12", "N=5 M=5", 1.5, 2.5),
            row("bcc_linear", "N=10 M=10", 0.5, 0.7),
            row("bcc7", "N=3 M=3", 0.9, 1.1),
        ]);
        assert!(v.contains("wins") && v.contains("bcc12 N=5 M=5 (2.00x)"), "{v}");
        assert!(v.contains("loses for bcc_linear N=10 M=10") && v.contains("1 tie"), "{v}");
    }
}
