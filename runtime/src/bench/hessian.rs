//! Second derivatives (`boxforge bench --hessian`): the generated
//! `<f>_eval_hessian` against the rivals a practitioner would write, timed in
//! interleaved rounds after checking that they agree: central differences of
//! the analytic gradient (`eval_grad` at p and at p +- h e_i, seven calls)
//! for every filter of degree >= 2, and for cc_tricubic the separable
//! tricubic Hessian (per-axis B-spline weights and their first and second
//! derivatives, contracted axis by axis, as Sigg & Hadwiger's GPU Gems 2
//! chapter 20 builds its derivative filters), hand-written here; for bcc7
//! Kim's method (one quartic, three cubic and six quadratic formulas on the
//! reference tetrahedron, cg-uos/bcc7) and for cc6 Kim & Kim 2023's (three
//! tetrahedron types, cg-uos/cc6), both written here in WGSL after the
//! authors' published GLSL (runtime/references/).

use super::job::{program, timed_rounds, Job};
use super::quality::points_in;
use super::stats::{median, Ratio};
use super::BenchError;
use crate::gpu::Gpu;
use crate::volume::{DeviceVolume, LatticeVolume};
use boxforge::emit::{emit, EmitOptions, Layout};
use serde::Serialize;
use std::fmt::Write as _;

/// Marks the section in BENCHMARKS.md.
pub const SECTION_START: &str = "<!-- hessian-bench:start -->";
/// Marks the end of the section.
pub const SECTION_END: &str = "<!-- hessian-bench:end -->";

/// The most a rival may differ (max |difference| / max(|value|, 1) over
/// the packed entries) and still count as computing the same Hessian: the
/// separable tricubic is exact (f32 rounding only); central differences
/// carry their truncation error and f32 cancellation.
pub fn agreement_tolerance(rival: &str) -> f64 {
    if rival == "central differences" {
        1e-2
    } else {
        1e-4
    }
}

/// Step of the central differences, in lattice units (1e-2 cell, as the
/// gradient bench's central differences of `eval`).
pub const CENTRAL_STEP: f32 = 0.01;

/// For C^1 filters, exact rivals are compared only at points farther than
/// this (lattice units) from every knot plane: on a plane the Hessian has two
/// right values, one per side, and f32 rounding of the locate picks either
/// (the gap is far above that rounding, about 1e-5 at these coordinates).
pub const KNOT_GAP: f32 = 1e-4;

/// Every entry of value, gradient and Hessian in one vec4 with distinct
/// weights (so a wrong entry changes the output and nothing is dead code).
fn packed(value: &str, gradient: &str, hessian: &str) -> String {
    format!(
        "vec4<f32>({hessian}[0] + 0.5 * {hessian}[1] + 0.25 * {hessian}[2], {value} + dot({gradient}, vec3<f32>(1.0, 0.5, 0.25)))"
    )
}

/// `bx_generated(p)`: the generated `eval_hessian`, packed.
fn generated(name: &str) -> String {
    format!(
        "fn bx_generated(p: vec3<f32>) -> vec4<f32> {{\n    let r = {name}_eval_hessian(p);\n    return {};\n}}\n",
        packed("r.value", "r.gradient", "r.hessian")
    )
}

/// `bx_central(p)`: value and gradient from `eval_grad(p)`, the Hessian's
/// columns from central differences of six more `eval_grad` calls.
fn central(name: &str) -> String {
    let h = CENTRAL_STEP;
    let inv = 0.5 / h;
    format!(
        "fn bx_central(p: vec3<f32>) -> vec4<f32> {{
    let g = {name}_eval_grad(p);
    let c0 = ({name}_eval_grad(p + vec3<f32>({h:?}, 0.0, 0.0)).yzw - {name}_eval_grad(p - vec3<f32>({h:?}, 0.0, 0.0)).yzw) * {inv:?};
    let c1 = ({name}_eval_grad(p + vec3<f32>(0.0, {h:?}, 0.0)).yzw - {name}_eval_grad(p - vec3<f32>(0.0, {h:?}, 0.0)).yzw) * {inv:?};
    let c2 = ({name}_eval_grad(p + vec3<f32>(0.0, 0.0, {h:?})).yzw - {name}_eval_grad(p - vec3<f32>(0.0, 0.0, {h:?})).yzw) * {inv:?};
    let hm = mat3x3<f32>(c0, c1, c2);
    return {};
}}
",
        packed("g.x", "g.yzw", "hm")
    )
}

/// The separable tricubic Hessian, hand-written
/// (runtime/references/separable_tricubic_hessian.wgsl).
pub const SEPARABLE_TRICUBIC: &str = crate::references::SEPARABLE_TRICUBIC_HESSIAN;

/// Rival name of Kim's bcc7 Hessian (runtime/references/kim_bcc7_hessian.wgsl).
pub const KIM_BCC7: &str = "Kim bcc7 (cg-uos/bcc7)";
/// Rival name of Kim & Kim's cc6 Hessian (runtime/references/kim_kim_cc6_hessian.wgsl).
pub const KIM_KIM_CC6: &str = "Kim & Kim 2023 cc6 (cg-uos/cc6)";

/// The hand-written rivals of `filter`: (name, WGSL, entry).
pub fn hand_written(filter: &str) -> Vec<(&'static str, &'static str, &'static str)> {
    match filter {
        "cc_tricubic" => vec![("separable tricubic", SEPARABLE_TRICUBIC, "bx_separable")],
        "bcc7" => vec![(KIM_BCC7, crate::references::KIM_BCC7_HESSIAN, "bx_kim_bcc7")],
        "cc6" => vec![(KIM_KIM_CC6, crate::references::KIM_KIM_CC6_HESSIAN, "bx_kim_cc6")],
        _ => Vec::new(),
    }
}

/// Is `p` farther than `dist` (Euclidean, lattice units) from every knot plane?
fn far_from_knot_planes(d: &boxforge::derive::Derivation, p: &[f32; 4], dist: f32) -> bool {
    let x = [p[0] as f64, p[1] as f64, p[2] as f64];
    crate::verify::nearest_knot_planes(d, &x).iter().all(|(n, _, gap, _)| {
        let norm = n.iter().map(|a| (a * a) as f64).sum::<f64>().sqrt();
        gap / norm > dist as f64
    })
}

/// One rival against the generated `eval_hessian`.
#[derive(Clone, Debug, Serialize)]
pub struct HessianRow {
    pub filter: String,
    /// `central differences`, or a hand-written rival of [`hand_written`].
    pub rival: String,
    pub generated_evals_per_s: f64,
    pub rival_evals_per_s: f64,
    /// Generated rate / rival rate per round (> 1: the generated is faster).
    pub speedup: Ratio,
    /// max over points and packed entries of |generated - rival| / max(|generated|, 1).
    pub max_rel_diff: f64,
    /// Points where the outputs were compared (all, or for a C^1 filter
    /// those farther than 2h (central differences) or [`KNOT_GAP`] (exact
    /// rivals) from every knot plane).
    pub compared_points: usize,
    /// Whether `max_rel_diff` is within [`agreement_tolerance`].
    pub agrees: bool,
    pub fetches_generated: usize,
    pub ops_generated: usize,
    pub hessian_form: String,
    /// Texel loads per evaluation of a hand-written rival without loops (naga's count).
    pub fetches_rival: Option<usize>,
    /// Arithmetic ops per evaluation of a hand-written rival without loops
    /// (`references::ops` on its source text, as the generated count).
    pub ops_rival: Option<usize>,
}

/// What `bench --hessian` measured.
#[derive(Clone, Debug, Serialize)]
pub struct HessianReport {
    pub adapter: String,
    pub points: usize,
    pub rounds: usize,
    pub rows: Vec<HessianRow>,
}

/// Times every filter's `eval_hessian` against its rivals on Marschner-Lobb
/// (41^3 samples' worth on each lattice), `points` points, `rounds` rounds.
pub fn run(
    gpu: &Gpu,
    filters: &[String],
    points: usize,
    rounds: usize,
    progress: &dyn Fn(&str),
) -> Result<HessianReport, BenchError> {
    let mut rows = Vec::new();
    for name in filters {
        let d = super::options::derive_filter(name)?;
        if d.facts.dim != 3 || d.facts.degree < 2 {
            continue;
        }
        let e3 = crate::scene::matched_edge(&d.filter.lattice, 41f64.powi(3));
        let ml = LatticeVolume::marschner_lobb(&d.filter.lattice, [e3, e3, e3])?;
        let dv = DeviceVolume::new(gpu, &ml, Layout::Embedded)?;
        let pts = points_in(&d, &ml, points, 9);
        let m = emit(&d, &EmitOptions { kernels: false, ..Default::default() })?;
        let mut rivals = vec![("central differences", central(name), "bx_central".to_string(), false)];
        for (rival, code, entry) in hand_written(name) {
            rivals.push((rival, code.to_string(), entry.to_string(), true));
        }
        for (rival, code, entry, hand) in rivals {
            let call = format!("{entry}(p)");
            let (fetches_rival, ops_rival) = if hand {
                let with = format!("{}\n{code}", m.source);
                // Counts on the text see a loop body once: none for loops.
                let loops = crate::references::code_only(&code).contains("for (");
                if loops {
                    (None, None)
                } else {
                    (
                        crate::references::fetches(&with, &code, &entry),
                        Some(crate::references::ops(&with, &code, &entry)),
                    )
                }
            } else {
                (None, None)
            };
            progress(&format!("{name}: eval_hessian vs {rival}, {rounds} rounds"));
            let a = Job::new(gpu, &program(&m.source, &generated(name), "bx_generated(p)"), "hessian", &dv, &pts)?;
            let b = Job::new(gpu, &program(&m.source, &code, &call), rival, &dv, &pts)?;
            let r = timed_rounds(gpu, &[&a, &b], rounds)?;
            // The outputs of the last round (each job writes every point each run).
            let (ao, bo) = (a.outputs(gpu)?, b.outputs(gpu)?);
            // Where the Hessian jumps (C^1 filters), central differences
            // straddling a knot plane blend both sides: compare them only
            // farther than 2h from every knot plane; exact rivals may pick
            // the other side on a plane: compare them farther than KNOT_GAP.
            let jumps = d.facts.continuity < 2;
            let gap = if hand { KNOT_GAP } else { 2.0 * CENTRAL_STEP };
            let compared: Vec<usize> =
                (0..pts.len()).filter(|&k| !jumps || far_from_knot_planes(&d, &pts[k], gap)).collect();
            let max_rel_diff = compared
                .iter()
                .flat_map(|&k| {
                    let (x, y) = (ao[k], bo[k]);
                    (0..4).map(move |i| (x[i] as f64 - y[i] as f64).abs() / (x[i] as f64).abs().max(1.0))
                })
                .fold(0f64, f64::max);
            rows.push(HessianRow {
                filter: name.clone(),
                rival: rival.into(),
                generated_evals_per_s: median(&r[0]),
                rival_evals_per_s: median(&r[1]),
                speedup: Ratio::of_rates(&r[0], &r[1]),
                max_rel_diff,
                compared_points: compared.len(),
                agrees: max_rel_diff <= agreement_tolerance(rival),
                fetches_generated: m.stats.fetches_per_eval,
                ops_generated: m.stats.ops_eval_hessian.unwrap_or(0),
                hessian_form: m.stats.hessian_form.map_or("-", |f| f.name()).into(),
                fetches_rival,
                ops_rival,
            });
        }
    }
    Ok(HessianReport { adapter: gpu.describe(), points, rounds, rows })
}

/// The section as Markdown, with each target and whether it holds.
pub fn markdown(r: &HessianReport, command: &str) -> String {
    let mut s = String::new();
    let _ = writeln!(s, "{SECTION_START}\n## Second derivatives: eval_hessian against its rivals\n");
    let _ = writeln!(s, "Generated by `{command}` on {}.\n", r.adapter);
    let _ = writeln!(
        s,
        "Marschner-Lobb at about 41^3 samples on each lattice, {} points in the valid box, median of {} interleaved rounds (ratio per round, min..max over rounds). Each kernel writes value, gradient and every Hessian entry folded into one vec4 with distinct weights; before timing, the rival's output is compared with the generated one (max |difference| / max(|value|, 1); central differences with h = {CENTRAL_STEP} differ by their truncation and f32 cancellation, about eps/h^2 of the data; for C^1 filters, whose Hessian jumps across knot planes, they are compared only at the points farther than 2h from every knot plane, since a difference straddling a plane blends both sides; exact rivals of a C^1 filter only farther than {KNOT_GAP:e}, since on a plane either side's Hessian is right and f32 rounding picks one). Targets: >= 3x central differences for every filter of degree >= 2; >= 1.0x each hand-written rival (cc_tricubic: the separable tricubic Hessian; bcc7: Kim's; cc6: Kim & Kim's). Fetches and ops of a hand-written rival are counted as the generated ones (naga's texel loads; arithmetic ops on the source text; none for code with loops).\n",
        r.points, r.rounds
    );
    let _ = writeln!(s, "| filter | eval_hessian form (fetches, ops) | rival (fetches, ops) | generated evals/s | rival evals/s | speed-up median [min..max] | target | max rel. difference (agrees?, points compared) |");
    let _ = writeln!(s, "|---|---|---|---:|---:|---|---|---|");
    for row in &r.rows {
        let want = if row.rival == "central differences" { 3.0 } else { 1.0 };
        let verdict = if row.speedup.median >= want {
            format!(">= {want}x: met")
        } else {
            format!(">= {want}x: missed by {:.2}x", want / row.speedup.median)
        };
        let _ = writeln!(
            s,
            "| {} | {} ({}, {}) | {} | {:.3e} | {:.3e} | {:.2}x [{:.2}..{:.2}] | {verdict} | {:.1e} ({}, tolerance {:.0e}, {} points) |",
            row.filter,
            row.hessian_form,
            row.fetches_generated,
            row.ops_generated,
            rival_cell(row),
            row.generated_evals_per_s,
            row.rival_evals_per_s,
            row.speedup.median,
            row.speedup.min,
            row.speedup.max,
            row.max_rel_diff,
            if row.agrees { "yes" } else { "NO" },
            agreement_tolerance(&row.rival),
            row.compared_points
        );
    }
    let _ = writeln!(
        s,
        "\nHand-written rivals (runtime/references/): the separable tricubic Hessian (per-axis B-spline weights and their derivatives, as Sigg & Hadwiger 2005 build derivative filters); Kim's bcc7 (M. Kim 2013, 2017, as published in the GitHub repository cg-uos/bcc7, bcc7_raycast_curvature.frag: one quartic, three cubic and six quadratic formulas on one reference tetrahedron, 30 fetches); Kim & Kim 2023's cc6 (Graphical Models 125, as published in cg-uos/cc6, cc6_raycast_curvature.frag: three tetrahedron types, 38 fetches, value and gradient formulas of all three types weighted by the type, the Hessian's by a switch). Both Kim rivals are our WGSL of the published method (those repositories carry no licence), with the published formulas' coefficients.\n"
    );
    let _ = writeln!(s, "{SECTION_END}");
    s
}

/// The rival's table cell: its name, and fetches and ops of a hand-written one.
fn rival_cell(row: &HessianRow) -> String {
    match (row.fetches_rival, row.ops_rival) {
        (Some(f), Some(o)) => format!("{} ({f}, {o})", row.rival),
        (Some(f), None) => format!("{} ({f}, -)", row.rival),
        _ => row.rival.clone(),
    }
}

/// `file` with this section replaced (or appended).
pub fn splice(file: &str, section: &str) -> String {
    super::derive::splice_between(file, section, SECTION_START, SECTION_END)
}

/// This section of `file`, if it has one.
pub fn existing_section(file: &str) -> Option<&str> {
    super::derive::section_between(file, SECTION_START, SECTION_END)
}
