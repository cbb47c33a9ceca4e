//! `boxforge bench --literature`: the reconstructions and renderers of the
//! source papers beside ours, measured in one run on the same data, with
//! each paper's qualitative claim and whether this measurement confirms it.
//!
//! Per scheme: RMS error against the analytic Marschner-Lobb function on
//! random points of a volume with (about) 41^3 samples on the scheme's
//! lattice, and evals/s of its evaluation function on those points (all
//! schemes interleaved in the same timed rounds). Mattausch et al.'s
//! bilinear and bilinear-plus-spatial schemes are the hand-written
//! references (`runtime/references/mattausch_bilinear.wgsl`, z stack);
//! sheared trilinear is the catalog's `bcc_sheared_trilinear` (reference
//! variant); barycentric on the Delaunay tetrahedra is `bcc_linear`. Then
//! projected tetrahedra (`crate::render::pt`) on BCC and on CC data of the same
//! sample count: ms per frame.

use super::{program, stats::median, timed_rounds, BenchError, Job};
use crate::gpu::Gpu;
use crate::references::MATTAUSCH_BILINEAR;
use crate::render::dvr::transfer::TransferFunction;
use crate::render::dvr::DvrOptions;
use crate::render::pt::tets::Grid;
use crate::volume::DeviceVolume;
use crate::volume::{marschner_lobb, ml_position, LatticeVolume};
use boxforge::derive::Derivation;
use boxforge::emit::{emit, EmitOptions, Layout};
use serde::Serialize;
use std::fmt::Write as _;

pub const SECTION_START: &str = "<!-- literature-bench:start -->";
pub const SECTION_END: &str = "<!-- literature-bench:end -->";

/// One reconstruction scheme measured.
#[derive(Clone, Debug, Serialize)]
pub struct SchemeRow {
    pub scheme: String,
    pub lattice: String,
    /// Where it comes from.
    pub source: String,
    pub samples: usize,
    pub rms_error: f64,
    /// Median over the rounds.
    pub evals_per_s: f64,
    /// evals/s of each round (the rounds interleave every scheme).
    pub rounds: Vec<f64>,
}

/// One renderer on the MNI head (DVR, mni-tissue preset).
#[derive(Clone, Debug, Serialize)]
pub struct MniRow {
    /// The scheme (ray cast) or "projected tetrahedra".
    pub renderer: String,
    pub lattice: String,
    pub samples: usize,
    pub ms_per_frame: f64,
    /// Bytes of the data on the device (the sample texture; for projected
    /// tetrahedra the packed samples and the visible-tetrahedra list).
    pub bytes: usize,
}

/// Projected tetrahedra on one lattice.
#[derive(Clone, Debug, Serialize)]
pub struct PtRow {
    /// The data set: Marschner-Lobb or the MNI head.
    pub data: String,
    pub lattice: String,
    pub samples: usize,
    pub tetrahedra_drawn: usize,
    pub ms_per_frame: f64,
}

/// What `bench --literature` measured.
#[derive(Clone, Debug, Serialize)]
pub struct LiteratureReport {
    pub adapter: String,
    pub points: usize,
    pub rounds: usize,
    pub schemes: Vec<SchemeRow>,
    pub pt: Vec<PtRow>,
    pub mni: Vec<MniRow>,
}

/// (scheme label, filter whose module it runs on, WGSL call of p, extra source, source).
fn schemes() -> Vec<(&'static str, &'static str, &'static str, &'static str, &'static str)> {
    vec![
        (
            "bilinear",
            "bcc_linear",
            "mattausch_bilinear(p, 2)",
            MATTAUSCH_BILINEAR,
            "Mattausch et al. 2003, 3.1 (hand-written)",
        ),
        (
            "bilinear + spatial",
            "bcc_linear",
            "mattausch_bilinear_spatial(p, 2)",
            MATTAUSCH_BILINEAR,
            "Mattausch et al. 2003, 3.2 (hand-written)",
        ),
        ("sheared trilinear", "bcc_sheared_trilinear", "", "", "Mattausch et al. 2003, 3.4 (catalog box spline)"),
        ("barycentric (bcc_linear)", "bcc_linear", "", "", "Mattausch et al. 2003, 3.3; Entezari et al. (catalog)"),
        ("bcc7", "bcc7", "", "", "Kim & Lee 2012; Kim 2013 (catalog)"),
        ("bcc8", "bcc8", "", "", "Entezari et al. (catalog)"),
        ("fcc6", "fcc6", "", "", "Kim 2013 (catalog)"),
        ("CC trilinear", "cc_trilinear", "", "", "the usual baseline (catalog)"),
        ("CC tricubic B-spline", "cc_tricubic", "", "", "Sigg & Hadwiger 2005 (catalog)"),
    ]
}

fn derive(name: &str) -> Result<Derivation, BenchError> {
    let f = boxforge::spec::catalog::get(name)?;
    Ok(Derivation::new(&f)?)
}

/// Runs the measurements: `points` random points per scheme, `rounds`
/// timed rounds, projected tetrahedra at `pt_size`^2 pixels (0: none).
pub fn run(
    gpu: &Gpu,
    points: usize,
    rounds: usize,
    pt_size: u32,
    mni: Option<&crate::volume::Volume>,
    progress: &dyn Fn(&str),
) -> Result<LiteratureReport, BenchError> {
    let budget = 41f64.powi(3);
    let mut jobs = Vec::new();
    let mut rows = Vec::new();
    for (label, filter, call, extra, source) in schemes() {
        progress(&format!("literature: {label}"));
        let d = derive(filter)?;
        let edge = crate::scene::matched_edge(&d.filter.lattice, budget);
        let vol = LatticeVolume::marschner_lobb(&d.filter.lattice, [edge; 3])?;
        let pts = super::quality::points_in(&d, &vol, points, 31);
        let m = emit(&d, &EmitOptions { kernels: false, ..Default::default() })?;
        let call = if call.is_empty() { format!("{}_eval(p)", d.filter.name) } else { call.to_string() };
        let src = program(&m.source, extra, &format!("vec4<f32>({call}, 0.0, 0.0, 0.0)"));
        let dv = DeviceVolume::new(gpu, &vol, Layout::Embedded)?;
        let job = Job::new(gpu, &src, label, &dv, &pts)?;
        job.time(gpu)?;
        let out = job.outputs(gpu)?;
        let sum: f64 = pts
            .iter()
            .zip(&out)
            .map(|(p, o)| {
                let x = ml_position(vol.dims, [p[0] as f64, p[1] as f64, p[2] as f64]);
                (o[0] as f64 - marschner_lobb(x)).powi(2)
            })
            .sum();
        rows.push(SchemeRow {
            scheme: label.into(),
            lattice: d.filter.lattice.name.clone(),
            source: source.into(),
            samples: vol.samples(),
            rms_error: (sum / pts.len() as f64).sqrt(),
            evals_per_s: 0.0,
            rounds: vec![],
        });
        jobs.push((job, dv));
    }
    progress("literature: timing every scheme in the same rounds");
    let refs: Vec<&Job> = jobs.iter().map(|(j, _)| j).collect();
    let rates = timed_rounds(gpu, &refs, rounds.max(1))?;
    for (row, r) in rows.iter_mut().zip(&rates) {
        row.evals_per_s = median(r);
        row.rounds = r.clone();
    }
    let mut pt = Vec::new();
    let mut mni_rows = Vec::new();
    if pt_size > 0 {
        let meshes = [Grid::Bcc, Grid::Cc]
            .map(|g| Derivation::new(&g.linear_filter()))
            .into_iter()
            .collect::<Result<Vec<_>, _>>()?;
        let ml_tf = TransferFunction::preset("marschner-lobb");
        let o = DvrOptions { width: pt_size, height: pt_size, frames: rounds.max(1), ..DvrOptions::default() };
        let pt_frame = |d: &Derivation, vol: &LatticeVolume, tf: &TransferFunction, o: &DvrOptions| {
            crate::render::pt::render::render(
                gpu,
                d,
                vol,
                tf,
                o,
                crate::render::pt::render::Shading::Phong,
                crate::render::pt::render::Normals::Vertex,
            )
            .map_err(BenchError::from)
        };
        for d in &meshes {
            progress(&format!("literature: projected tetrahedra on {} (Marschner-Lobb)", d.filter.lattice.name));
            let edge = crate::scene::matched_edge(&d.filter.lattice, budget);
            let vol = LatticeVolume::marschner_lobb(&d.filter.lattice, [edge; 3])?;
            let (frame, stats) = pt_frame(d, &vol, &ml_tf, &o)?;
            pt.push(PtRow {
                data: "Marschner-Lobb".into(),
                lattice: d.filter.lattice.name.clone(),
                samples: vol.samples(),
                tetrahedra_drawn: stats.drawn,
                ms_per_frame: frame.ms_per_frame,
            });
        }
        if let Some(head) = mni {
            // The head resampled on each lattice at the Cartesian sample count
            // (as the demo does), rendered by each ray-cast scheme and by PT.
            let tf = TransferFunction::preset("mni-tissue");
            let o = DvrOptions { step: 1.0, azimuth: 200.0, elevation: 15.0, ..o.clone() };
            let volume_on = |d: &Derivation| {
                crate::scene::from_cartesian(head, &d.filter.lattice, crate::scene::Conversion::Resample)
                    .map_err(BenchError::from)
            };
            let view = crate::render::iso::view_direction(o.azimuth, o.elevation);
            for (label, filter, call, _, _) in schemes() {
                progress(&format!("literature: {label} on the MNI head"));
                let mut d = derive(filter)?;
                let vol = volume_on(&d)?;
                let (frame, renderer) = if call.is_empty() {
                    // View-dependent filters (sheared trilinear) ray cast the
                    // variant of this view, as `render` does.
                    let mut renderer = format!("{label}, ray cast");
                    if d.filter.view_dependent {
                        let (f, _) = d.filter.view_variant(view)?;
                        d = Derivation::new(&f)?;
                        renderer.push_str(" (the view's variant)");
                    }
                    (crate::render::dvr::render(gpu, &d, &vol, Layout::Embedded, &tf, &o)?, renderer)
                } else {
                    // The hand-written plane-stack schemes, stack chosen from the view.
                    let scheme = if call.starts_with("mattausch_bilinear_spatial") {
                        crate::render::schemes::Scheme::BilinearSpatial
                    } else {
                        crate::render::schemes::Scheme::Bilinear
                    };
                    let axis = crate::render::schemes::stack_for_view(view);
                    let (frame, _) = crate::render::schemes::render(gpu, &vol, scheme, &tf, &o)?;
                    (frame, format!("{label}, ray cast ({} stack, from the view)", ["x", "y", "z"][axis]))
                };
                mni_rows.push(MniRow {
                    renderer,
                    lattice: d.filter.lattice.name.clone(),
                    samples: vol.samples(),
                    ms_per_frame: frame.ms_per_frame,
                    bytes: vol.data.len() * 4,
                });
            }
            for d in &meshes {
                progress(&format!("literature: projected tetrahedra on {} (MNI head)", d.filter.lattice.name));
                let vol = volume_on(d)?;
                let (frame, stats) = pt_frame(d, &vol, &tf, &o)?;
                let grid = Grid::of(&d.filter.lattice).expect("BCC or CC");
                let bytes = crate::render::pt::render::packed_data(&vol, grid).len() * 4 + stats.drawn * 4;
                mni_rows.push(MniRow {
                    renderer: "projected tetrahedra".into(),
                    lattice: d.filter.lattice.name.clone(),
                    samples: vol.samples(),
                    ms_per_frame: frame.ms_per_frame,
                    bytes,
                });
                pt.push(PtRow {
                    data: "MNI head".into(),
                    lattice: d.filter.lattice.name.clone(),
                    samples: vol.samples(),
                    tetrahedra_drawn: stats.drawn,
                    ms_per_frame: frame.ms_per_frame,
                });
            }
        }
    }
    Ok(LiteratureReport { adapter: gpu.describe(), points, rounds, schemes: rows, pt, mni: mni_rows })
}

/// A claim of the papers and what the measurement says about it.
#[derive(Clone, Debug, PartialEq)]
pub struct Verdict {
    pub claim: &'static str,
    pub measured: String,
    pub confirmed: Option<bool>,
}

fn find<'a>(r: &'a LiteratureReport, scheme: &str) -> Option<&'a SchemeRow> {
    r.schemes.iter().find(|s| s.scheme == scheme)
}

/// Mattausch et al.'s claims (seed 003, section 5) checked on the rows.
pub fn verdicts(r: &LiteratureReport) -> Vec<Verdict> {
    let mut v = Vec::new();
    let bcc = ["bilinear", "bilinear + spatial", "sheared trilinear", "barycentric (bcc_linear)"];
    let rows: Vec<&SchemeRow> = bcc.iter().filter_map(|s| find(r, s)).collect();
    let rms = |s: &str| find(r, s).map(|x| x.rms_error);
    if rows.len() == bcc.len() {
        let fastest = rows.iter().max_by(|a, b| a.evals_per_s.total_cmp(&b.evals_per_s)).expect("rows");
        v.push(Verdict {
            claim: "bilinear is the fastest BCC scheme",
            measured: format!("fastest: {} ({:.3e} evals/s)", fastest.scheme, fastest.evals_per_s),
            confirmed: Some(fastest.scheme == "bilinear"),
        });
        let slowest = rows.iter().min_by(|a, b| a.evals_per_s.total_cmp(&b.evals_per_s)).expect("rows");
        v.push(Verdict {
            claim: "barycentric is the slowest BCC scheme",
            measured: format!("slowest: {} ({:.3e} evals/s)", slowest.scheme, slowest.evals_per_s),
            confirmed: Some(slowest.scheme == "barycentric (bcc_linear)"),
        });
        let best = [rms("sheared trilinear"), rms("bilinear + spatial")].map(|x| x.unwrap_or(f64::NAN));
        let others = [rms("bilinear"), rms("barycentric (bcc_linear)")].map(|x| x.unwrap_or(f64::NAN));
        v.push(Verdict {
            claim: "sheared trilinear and bilinear + spatial give the best BCC images (here: lowest RMS error)",
            measured: format!(
                "RMS sheared {:.4}, bil+spat {:.4}; bilinear {:.4}, barycentric {:.4}",
                best[0], best[1], others[0], others[1]
            ),
            confirmed: Some(best.iter().all(|b| others.iter().all(|o| b <= o))),
        });
    }
    if let (Some(cc), Some(sh), Some(bs)) =
        (find(r, "CC trilinear"), find(r, "sheared trilinear"), find(r, "bilinear + spatial"))
    {
        // Per-round ratios: a claim holds when every round agrees, fails
        // when every round of one scheme disagrees, and is a tie otherwise.
        let per_round = |x: &SchemeRow| -> Vec<f64> { x.rounds.iter().zip(&cc.rounds).map(|(a, b)| a / b).collect() };
        let (rs, rb) = (per_round(sh), per_round(bs));
        let confirmed = if rs.is_empty() || rb.is_empty() {
            Some(sh.evals_per_s < cc.evals_per_s && bs.evals_per_s < cc.evals_per_s)
        } else if rs.iter().chain(&rb).all(|&q| q < 1.0) {
            Some(true)
        } else if rs.iter().all(|&q| q >= 1.0) || rb.iter().all(|&q| q >= 1.0) {
            Some(false)
        } else {
            None
        };
        let span = |q: &[f64]| {
            let lo = q.iter().copied().fold(f64::INFINITY, f64::min);
            let hi = q.iter().copied().fold(f64::NEG_INFINITY, f64::max);
            if q.is_empty() {
                String::new()
            } else {
                format!(" [{lo:.2}..{hi:.2}]")
            }
        };
        v.push(Verdict {
            claim: "sheared trilinear and bilinear + spatial are slightly slower than CC trilinear",
            measured: format!(
                "evals/s relative to CC trilinear, median [rounds]: sheared {:.2}{}, bil+spat {:.2}{}",
                sh.evals_per_s / cc.evals_per_s,
                span(&rs),
                bs.evals_per_s / cc.evals_per_s,
                span(&rb)
            ),
            confirmed,
        });
    }
    let mut parts = Vec::new();
    let mut all_faster = true;
    for b in r.pt.iter().filter(|p| p.lattice == "bcc") {
        if let Some(c) = r.pt.iter().find(|p| p.lattice == "cc" && p.data == b.data) {
            parts.push(format!(
                "{}: BCC {:.0} ms ({} tetrahedra), CC {:.0} ms ({} tetrahedra)",
                b.data, b.ms_per_frame, b.tetrahedra_drawn, c.ms_per_frame, c.tetrahedra_drawn
            ));
            all_faster &= b.ms_per_frame < c.ms_per_frame;
        }
    }
    if !parts.is_empty() {
        v.push(Verdict {
            claim: "projected tetrahedra are faster on BCC than on CC at the same sample count, on every data set",
            measured: parts.join("; "),
            confirmed: Some(all_faster),
        });
    }
    v
}

/// The markdown section (between [`SECTION_START`] and [`SECTION_END`]).
pub fn markdown(r: &LiteratureReport, command: &str) -> String {
    let mut s = String::new();
    let _ = writeln!(s, "{SECTION_START}\n## Renderers of the literature\n");
    let _ = writeln!(
        s,
        "Written by `{command}` on {}. Marschner-Lobb with about 41^3 samples on each scheme's lattice; RMS error against the analytic function at {} random points; evals/s of each scheme's evaluation on those points, all schemes in the same {} timed rounds (median). Mattausch et al.'s bilinear schemes use the z plane stack (runtime/references/mattausch_bilinear.wgsl).\n",
        r.adapter, r.points, r.rounds
    );
    let _ = writeln!(s, "| scheme | lattice | source | samples | RMS error | evals/s |\n|---|---|---|---|---|---|");
    for x in &r.schemes {
        let _ = writeln!(
            s,
            "| {} | {} | {} | {} | {:.4} | {:.3e} |",
            x.scheme, x.lattice, x.source, x.samples, x.rms_error, x.evals_per_s
        );
    }
    if !r.pt.is_empty() {
        let _ = writeln!(s, "\nProjected tetrahedra (`render --renderer pt`, Phong on vertex normals; Marschner-Lobb with its preset, the MNI head with mni-tissue):\n\n| data | lattice | samples | tetrahedra drawn | ms/frame |\n|---|---|---|---|---|");
        for p in &r.pt {
            let _ = writeln!(
                s,
                "| {} | {} | {} | {} | {:.1} |",
                p.data, p.lattice, p.samples, p.tetrahedra_drawn, p.ms_per_frame
            );
        }
    }
    if !r.mni.is_empty() {
        let _ = writeln!(s, "\nThe MNI head (box-averaged to 2 mm, resampled on each lattice at the Cartesian sample count), DVR with mni-tissue, step 1. Bytes: the embedded layout's sample texture (on BCC and FCC it spans the whole integer box, 4 and 2 times the samples; the packed layout holds the samples only), for projected tetrahedra the packed samples and the visible-tetrahedra list:\n\n| renderer | lattice | samples | ms/frame | bytes on the device |\n|---|---|---|---|---|");
        for m in &r.mni {
            let _ =
                writeln!(s, "| {} | {} | {} | {:.1} | {} |", m.renderer, m.lattice, m.samples, m.ms_per_frame, m.bytes);
        }
    }
    let _ = writeln!(s, "\n| the paper's claim | measured here | confirmed? |\n|---|---|---|");
    for v in verdicts(r) {
        let c = match v.confirmed {
            Some(true) => "yes",
            Some(false) => "no",
            None => "tie (the rounds disagree)",
        };
        let _ = writeln!(s, "| {} | {} | {c} |", v.claim, v.measured);
    }
    let _ = writeln!(s, "{SECTION_END}");
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

    fn row(scheme: &str, rms: f64, rate: f64) -> SchemeRow {
        SchemeRow {
            scheme: scheme.into(),
            lattice: "bcc".into(),
            source: String::new(),
            samples: 1,
            rms_error: rms,
            evals_per_s: rate,
            rounds: vec![rate],
        }
    }

    #[test]
    fn verdicts_follow_the_numbers() {
        let mut r = LiteratureReport {
            adapter: "test".into(),
            points: 1,
            rounds: 1,
            schemes: vec![
                row("bilinear", 0.3, 9.0),
                row("bilinear + spatial", 0.1, 5.0),
                row("sheared trilinear", 0.1, 6.0),
                row("barycentric (bcc_linear)", 0.2, 2.0),
                row("CC trilinear", 0.2, 7.0),
            ],
            pt: vec![],
            mni: vec![],
        };
        let v = verdicts(&r);
        assert_eq!(v.len(), 4);
        assert!(v.iter().all(|x| x.confirmed == Some(true)), "{v:?}");
        // Make bilinear slow and bilinear + spatial worse than barycentric: both verdicts flip.
        r.schemes[0].evals_per_s = 1.0;
        r.schemes[1].rms_error = 0.25;
        let v = verdicts(&r);
        assert_eq!(v[0].confirmed, Some(false), "{:?}", v[0]);
        assert_eq!(v[1].confirmed, Some(false), "bilinear is now the slowest");
        assert_eq!(v[2].confirmed, Some(false), "{:?}", v[2]);
        // Rounds that split around CC trilinear's rate make a tie; all above, a failure.
        r.schemes[1].rounds = vec![6.0, 8.0];
        r.schemes[2].rounds = vec![6.0, 6.5];
        r.schemes[4].rounds = vec![7.0, 7.0];
        assert_eq!(verdicts(&r)[3].confirmed, None, "{:?}", verdicts(&r)[3]);
        r.schemes[1].rounds = vec![8.0, 9.0];
        assert_eq!(verdicts(&r)[3].confirmed, Some(false));
        let md = markdown(&r, "boxforge bench --literature");
        assert!(md.starts_with(SECTION_START) && md.trim_end().ends_with(SECTION_END));
        let spliced = splice(&format!("# B\n\n{md}\n\ntail\n"), &markdown(&r, "again"));
        assert!(spliced.contains("again") && spliced.contains("tail") && spliced.matches(SECTION_START).count() == 1);
    }
}
