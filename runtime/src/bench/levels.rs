//! The quality of pyramid levels for spline reconstruction: Marschner-Lobb
//! sampled at n^3 and written as an OME-Zarr pyramid by each reduction
//! (`volume::zarr::write_pyramid`: subsampling, the tent (1,2,1)/4, the
//! 2x2x2 box mean, the binomial (1,4,6,4,1)/16), each level read back and reconstructed with a
//! filter (CPU, the exact pieces in f64) at seeded points of the central
//! half of the volume, against the analytic function: the RMS error per
//! level, reduction and filter.

use crate::verify::Rng;
use crate::volume::zarr::{write_pyramid, OmeZarr, PyramidOptions, Reduction, Selection, ZarrType, ZarrVolume};
use crate::volume::{marschner_lobb, ml_position, BrickSource, LatticeVolume, VolumeError};
use boxforge::derive::Derivation;
use std::fmt::Write as _;
use std::path::Path;

pub const SECTION_START: &str = "<!-- levels-bench:start -->";
pub const SECTION_END: &str = "<!-- levels-bench:end -->";

/// The reductions compared, in the table's column order.
pub const REDUCTIONS: [Reduction; 4] = [Reduction::Subsample, Reduction::Tent, Reduction::Box, Reduction::Binomial];

/// One filter at one level: the RMS error per reduction (in [`REDUCTIONS`] order).
#[derive(Clone, Debug, serde::Serialize)]
pub struct LevelRow {
    pub filter: String,
    pub level: usize,
    /// Samples along each axis at this level (binomial and subsample; the box level has one fewer when odd).
    pub edge: usize,
    pub rms: Vec<f64>,
}

/// The measurement.
#[derive(Clone, Debug, serde::Serialize)]
pub struct LevelsReport {
    pub edge0: usize,
    pub levels: usize,
    pub points: usize,
    pub rows: Vec<LevelRow>,
}

/// Where level k's sample j sits in level-0 sample coordinates: j 2^k,
/// plus (2^k - 1)/2 for the cell-centred box mean.
fn level_offset(r: Reduction, k: usize) -> f64 {
    match r {
        Reduction::Box => ((1u64 << k) as f64 - 1.0) / 2.0,
        _ => 0.0,
    }
}

/// Writes the pyramids into `scratch` (a folder of its own) and measures
/// every filter of `filters` at every level.
pub fn measure(
    filters: &[Derivation],
    edge0: usize,
    levels: usize,
    points: usize,
    scratch: &Path,
    progress: &dyn Fn(&str),
) -> Result<LevelsReport, VolumeError> {
    let cc = boxforge::spec::lattice::Lattice::builtin("cc")
        .map_err(|e| VolumeError::BadDims { dims: [edge0; 3], reason: e.to_string() })?;
    let dims0 = [edge0; 3];
    let source = LatticeVolume::marschner_lobb(&cc, dims0)?;
    // Per reduction, each level's samples.
    let mut pyramids: Vec<Vec<(Vec<f32>, [usize; 3])>> = Vec::new();
    for r in REDUCTIONS {
        progress(&format!("writing the {} pyramid of Marschner-Lobb {edge0}^3", r.name()));
        let out = scratch.join(format!("{}.zarr", r.name()));
        let o =
            PyramidOptions { chunk: 32, levels: Some(levels), reduction: r, ty: ZarrType::F32, ..Default::default() };
        write_pyramid(&source, &out, &o, &|_, _| {})?;
        let image = OmeZarr::open(&out)?;
        let mut per_level = Vec::new();
        for k in 0..image.levels().len() {
            let v = ZarrVolume::new(&image, Selection { level: k, ..Default::default() }, &cc)?;
            let d = v.dims();
            let mut data = vec![0f32; d.iter().product()];
            v.read_box([0, 0, 0], d, &mut data)?;
            per_level.push((data, d));
        }
        pyramids.push(per_level);
    }
    // Seeded points of the central half, in level-0 sample coordinates.
    let mut rng = Rng(0x1e7e15);
    let pts: Vec<[f64; 3]> =
        (0..points).map(|_| std::array::from_fn(|_| (edge0 as f64 - 1.0) * (0.25 + 0.5 * rng.next_f64()))).collect();
    let truth: Vec<f64> = pts.iter().map(|p| marschner_lobb(ml_position(dims0, *p))).collect();
    let mut rows = Vec::new();
    for d in filters {
        for k in 0..levels {
            progress(&format!("{}: level {k}", d.filter.name));
            let mut rms = Vec::new();
            for (r, pyramid) in REDUCTIONS.iter().zip(&pyramids) {
                let (data, dk) = &pyramid[k];
                let at = |j: &[i64]| {
                    let c: [usize; 3] = std::array::from_fn(|a| j[a].clamp(0, dk[a] as i64 - 1) as usize);
                    f64::from(data[c[0] + dk[0] * (c[1] + dk[1] * c[2])])
                };
                let scale = (1u64 << k) as f64;
                let sum: f64 = pts
                    .iter()
                    .zip(&truth)
                    .map(|(p, t)| {
                        let u: Vec<f64> = p.iter().map(|x| (x - level_offset(*r, k)) / scale).collect();
                        let (v, _) = d.eval_f64(&u, &at);
                        (v - t) * (v - t)
                    })
                    .sum();
                rms.push((sum / points as f64).sqrt());
            }
            rows.push(LevelRow { filter: d.filter.name.clone(), level: k, edge: edge0.div_ceil(1 << k), rms });
        }
    }
    Ok(LevelsReport { edge0, levels, points, rows })
}

/// The section as Markdown.
pub fn markdown(r: &LevelsReport, command: &str) -> String {
    let mut s = String::new();
    let _ = writeln!(s, "{SECTION_START}\n## Pyramid levels for spline reconstruction\n");
    let _ = writeln!(s, "Generated by `{command}` (CPU, the exact pieces evaluated in f64).\n");
    let _ = writeln!(
        s,
        "Marschner-Lobb (alpha 0.25, f_M 6) sampled at {e}^3 over [-1, 1]^3, written by `boxforge convert`'s writer as a {l}-level OME-Zarr pyramid (float32) with each reduction, each level read back and reconstructed with the filter at {p} seeded points of the central half of the volume (level k's sample j at level-0 position j 2^k, plus (2^k - 1)/2 for the cell-centred box mean), against the analytic function: the RMS error (the function spans [0, 1]). Subsample keeps every second sample (what a pyramid without a low-pass does); tent is (1, 2, 1)/4 per axis then every second sample; box is the 2x2x2 mean; binomial is (1, 4, 6, 4, 1)/16 per axis then every second sample.\n",
        e = r.edge0,
        l = r.levels,
        p = r.points
    );
    let names: Vec<&str> = REDUCTIONS.iter().map(|x| x.name()).collect();
    let _ = writeln!(s, "| filter | level | samples per axis | RMS, {} | lowest |", names.join(" | RMS, "));
    let _ = writeln!(s, "|---|---:|---:|{}---|", "---:|".repeat(names.len()));
    for row in &r.rows {
        let cells: Vec<String> = row.rms.iter().map(|v| format!("{v:.4}")).collect();
        let best = (0..row.rms.len()).min_by(|&a, &b| row.rms[a].total_cmp(&row.rms[b])).unwrap_or(0);
        let lowest = if row.level == 0 { "(the same samples)" } else { names[best] };
        let _ = writeln!(s, "| {} | {} | {} | {} | {lowest} |", row.filter, row.level, row.edge, cells.join(" | "));
    }
    let _ = writeln!(s, "\n{SECTION_END}");
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
