//! docs/BENCHMARKS.md from a report.

use super::compare::RAY_STEPS;
use super::rows::{GlslRivalRow, TAG_LINEAR};
use super::stats::{self, Ratio};
use super::{dvr, BenchReport, REFERENCE_TOLERANCE};

pub(super) fn ratio_cells(r: &Option<Ratio>) -> (String, String) {
    match r {
        Some(r) => (format!("{:.2} [{:.2}..{:.2}]", r.median, r.min, r.max), if r.tie { "tie" } else { "" }.into()),
        None => (String::new(), String::new()),
    }
}

/// The heading of the generated-vs-hand-written section.
pub const REFERENCES_HEADING: &str = "## Generated vs hand-written";

/// The generated-vs-hand-written section (heading, method, table, then the
/// GLSL subsection of `glsl` rows when there are any), ending with a blank
/// line. `measured_by`: the line saying which separate run measured it,
/// when it is spliced into a file written by another run.
pub fn references_section(rows: &[super::ReferenceRow], glsl: &[GlslRivalRow], measured_by: Option<&str>) -> String {
    use std::fmt::Write;
    let mut s = String::new();
    let _ = writeln!(
        s,
        "{REFERENCES_HEADING}\n\n{}The generated `<filter>_eval` beside hand-written shaders (runtime/references/, embedded in the binary; each cites its source), on the same random points of a random 64^3-ish volume, after checking max |generated - reference| < {:.0e} of the data range on those points (a comparison that fails the check is marked INVALID and not timed). Ratio: generated ÷ reference evals/s (above 1: the generated code is faster). Ops: `boxforge::emit::count_ops` on the generated eval body; on the reference, the same count over its entry function and, per call site, its own helpers (a vec4 `dot` counts 7), calls to `<filter>_fetch` excluded on both sides; fetches: texel loads over the call tree (naga) plus filtered fetches. Loads only: the generated eval cut after its fetches (same point location, addressing and clamped loads, returning the mean of the samples), timed in the same rounds, ÷ the reference: no evaluation with these loads can be faster, so it bounds the ratio reachable with exact loads on this adapter. Two kernel shapes, timed in the same interleaved rounds: one evaluation per invocation (the ratio and loads-only columns), and the ray-caster shape ({} evaluations per invocation a quarter cell apart along a short path, summed, one write: the \"ray\" columns); where the two ratios differ by more than {:.0}% the row says so.\n", measured_by.map(|m| format!("{m}\n\n")).unwrap_or_default(), REFERENCE_TOLERANCE, super::compare::RAY_STEPS, super::compare::SHAPE_DISAGREEMENT * 100.0
    );
    let _ = writeln!(s, "| generated | reference | fetches (gen / ref) | ops (gen / ref) | generated evals/s | reference evals/s | ratio median [min..max] | tie? | loads only ÷ reference | ray: ratio | ray: loads only ÷ reference | max \\|diff\\| (of range) | source |\n|---|---|---|---|---|---|---|---|---|---|---|---|---|");
    for x in rows {
        let (ratio, tie) = ratio_cells(&x.ratio);
        let diff = match (x.max_abs_diff, x.rel_diff) {
            (Some(a), Some(rel)) => format!("{a:.2e} ({rel:.1e})"),
            _ => String::new(),
        };
        let status = if let Some(n) = &x.note {
            if x.agrees {
                n.clone()
            } else {
                format!("**{n}**")
            }
        } else {
            String::new()
        };
        let _ = writeln!(
            s,
            "| `{}` | {} (`{}`) | {} / {} | {} / {} | {} | {} | {}{} | {} | {} | {} | {} | {} | {} |",
            x.generated,
            x.reference,
            x.entry,
            x.generated_fetches,
            x.reference_fetches.map(|f| f.to_string()).unwrap_or_else(|| "?".into()),
            x.generated_ops,
            x.reference_ops,
            x.generated_evals_per_s.map(|v| format!("{v:.3e}")).unwrap_or_default(),
            x.reference_evals_per_s.map(|v| format!("{v:.3e}")).unwrap_or_default(),
            ratio,
            if status.is_empty() { String::new() } else { format!(" {status}") },
            tie,
            ratio_cells(&x.loads_only_ratio).0,
            ratio_cells(&x.ray_ratio).0,
            ratio_cells(&x.ray_loads_only_ratio).0,
            diff,
            x.citation
        );
    }
    if rows.is_empty() {
        let _ = writeln!(s, "| (no references in this run) | | | | | | | | | | | | |");
    }
    s.push('\n');
    s.push_str(&glsl_rivals_markdown(glsl));
    s
}

/// `file` with its generated-vs-hand-written section (up to the next `## `
/// heading) replaced by `section`, or `section` appended.
pub fn splice_references(file: &str, section: &str) -> String {
    let Some(a) = file.find(REFERENCES_HEADING) else {
        return format!("{}\n\n{}", file.trim_end(), section);
    };
    let after = a + REFERENCES_HEADING.len();
    match file[after..].find("\n## ") {
        Some(k) => format!("{}{}\n{}", &file[..a], section.trim_end(), &file[after + k..]),
        None => format!("{}{}\n", &file[..a], section.trim_end()),
    }
}

/// docs/BENCHMARKS.md from a report.
pub fn markdown(r: &BenchReport, command: &str) -> String {
    use std::fmt::Write;
    let mut s = String::new();
    let _ = writeln!(s, "<!-- generated by `{command}`; do not edit -->\n\n# Benchmarks\n");
    if !r.complete {
        let _ = writeln!(s, "**Partial run**: the sections below hold what was measured before the run stopped.\n");
    }
    let _ = writeln!(s, "Machine: {}  \nAdapter: {}  \nTiming: {}.\n", r.machine, r.adapter, r.timing);
    let _ = writeln!(
        s,
        "All ratios are measured in this one run: each comparison in {} interleaved rounds, the ratio taken per round; \"median [min..max]\" is over the rounds, and a range that spans 1.0 is a tie.\n",
        r.rounds
    );
    s.push_str(&references_section(&r.references, &r.glsl_references, None));
    let _ = writeln!(s, "## Evaluation throughput\n\n| filter | layout | variant | kind | evals/s | ratio median [min..max] | tie? | baseline | fetches | ops | sample bytes |\n|---|---|---|---|---|---|---|---|---|---|---|");
    for row in r.rows.iter().filter(|x| x.evals_per_s.is_some()) {
        let (ratio, tie) = ratio_cells(&row.ratio);
        let _ = writeln!(
            s,
            "| {} | {} | {} | {} | {:.3e} | {} | {} | {} | {} | {} | {} |",
            row.filter,
            row.layout,
            row.variant,
            row.kind,
            row.evals_per_s.unwrap_or(0.0),
            ratio,
            tie,
            row.baseline.clone().unwrap_or_default(),
            row.fetches.map(|x| x.to_string()).unwrap_or_default(),
            row.ops.map(|x| x.to_string()).unwrap_or_default(),
            row.bytes.map(|x| x.to_string()).unwrap_or_default(),
        );
    }
    let linear: Vec<String> = r
        .rows
        .iter()
        .filter(|x| x.variant.contains(TAG_LINEAR) && x.kind == "eval")
        .filter_map(|x| {
            let (cell, _) = ratio_cells(&x.ratio);
            let err = x
                .max_rel_diff_to_baseline
                .map(|d| format!(", max |linear - exact| {d:.1e} of the range"))
                .unwrap_or_default();
            (!cell.is_empty())
                .then(|| format!("{} {} {} fetches: {cell}{err}", x.filter, x.layout, x.fetches.unwrap_or(0)))
        })
        .collect();
    if !linear.is_empty() {
        let _ = writeln!(
            s,
            "\n### Linear fetches\n\nlinear ÷ exact fetches, eval, on this adapter: {}. A filtered fetch pays off where a texture unit interpolates at the cost of one load. lavapipe (llvmpipe) filters in software, so there a filtered fetch costs more than a texel load, and the per-sample weights (their pair sums and ratios) cost more arithmetic than the combined forms of exact loads: pairs that each replace two loads (bcc7, bcc8, fcc6 on the packed layout) are expected to lose on lavapipe, while trilinear fetches that each replace eight (the tricubic, embedded) win. Run `boxforge bench` on a GPU before choosing.",
            linear.join("; ")
        );
    }
    let naive: Vec<f64> = r.rows.iter().filter(|x| x.variant == "naive").filter_map(|x| x.ratio_to_baseline).collect();
    let this_run = if naive.is_empty() {
        "no naive variant was timed in this run".to_string()
    } else {
        let (lo, hi) = stats::range(&naive);
        format!("{lo:.0}x to {hi:.0}x in this run")
    };
    let _ = writeln!(
        s,
        "\n### Fast vs naive\n\nThe large fast ÷ naive ratios on lavapipe ({this_run}; 1,000x to 15,000x for fcc6 and bcc7 in full runs) come from lavapipe's handling of dynamic indexing into private arrays: the naive variant keeps its stencil offsets and piece coefficients in lookup tables indexed at run time and loops over them, and llvmpipe lowers such indexing to slow scratch-memory code. They do not come from branches as such, and a GPU with register-indexed constant tables would show a far smaller gap; measure it there before citing a number."
    );
    let _ = writeln!(
        s,
        "\n## Rendering\n\n| filter | image | variant | ms/frame | ratio median [min..max] | tie? | baseline |\n|---|---|---|---|---|---|---|"
    );
    for row in r.rows.iter().filter(|x| x.ms_per_frame.is_some()) {
        let (ratio, tie) = ratio_cells(&row.ratio);
        let _ = writeln!(
            s,
            "| {} | {} | {} | {:.1} | {} | {} | {} |",
            row.filter,
            row.kind,
            row.variant,
            row.ms_per_frame.unwrap_or(0.0),
            ratio,
            tie,
            row.baseline.clone().unwrap_or_default()
        );
    }
    s.push_str(&dvr::markdown(&r.rows));
    let _ = writeln!(s, "\n## Analytic gradient vs central differences (Marschner-Lobb)\n\n| filter | analytic evals/s | central evals/s | speed-up median [min..max] | tie? | analytic angle error (°) | central angle error (°) |\n|---|---|---|---|---|---|---|");
    for g in &r.gradient {
        let (ratio, tie) = ratio_cells(&Some(g.speedup_ratio));
        let _ = writeln!(
            s,
            "| {} | {:.3e} | {:.3e} | {} | {} | {:.3} | {:.3} |",
            g.filter,
            g.analytic_evals_per_s,
            g.central_evals_per_s,
            ratio,
            tie,
            g.analytic_angle_deg,
            g.central_angle_deg
        );
    }
    let _ = writeln!(s, "\n## Quality against the analytic Marschner-Lobb function\n\n| filter | lattice | budget | samples | prefiltered | RMS error | max error | gradient angle error (°) |\n|---|---|---|---|---|---|---|---|");
    for q in &r.quality {
        let _ = writeln!(
            s,
            "| {} | {} | {} | {} | {} | {:.5} | {:.4} | {:.2} |",
            q.filter, q.lattice, q.budget, q.samples, q.prefiltered, q.rms_error, q.max_error, q.gradient_angle_deg
        );
    }
    let _ = writeln!(s, "\n## Convergence on a smooth signal (prefiltered)\n\n| filter | approximation order | edges | RMS errors | measured order |\n|---|---|---|---|---|");
    for c in &r.convergence {
        let _ = writeln!(
            s,
            "| {} | {} | {:?} | {} | {:.2} |",
            c.filter,
            c.approximation_order,
            c.edges,
            c.rms_errors.iter().map(|e| format!("{e:.2e}")).collect::<Vec<_>>().join(", "),
            c.measured_order
        );
    }
    s
}

/// Marks the hand-kept record of runs on lent GPUs in BENCHMARKS.md (the
/// main report keeps it, as it keeps the other modes' sections).
pub const GPU_RECORD_START: &str = "<!-- gpu-record:start -->";
/// Marks the end of that record.
pub const GPU_RECORD_END: &str = "<!-- gpu-record:end -->";

/// The GPU record of an existing BENCHMARKS.md, if any.
pub fn gpu_record_section(file: &str) -> Option<&str> {
    super::derive::section_between(file, GPU_RECORD_START, GPU_RECORD_END)
}

/// The heading of the GLSL subsection of "## Generated vs hand-written".
pub const GLSL_HEADING: &str = "### In GLSL (glslang → SPIR-V, passthrough)";

/// The GLSL subsection (heading, method, table), ending with a blank line;
/// empty when there are no rows.
pub fn glsl_rivals_markdown(rows: &[GlslRivalRow]) -> String {
    use std::fmt::Write;
    if rows.is_empty() {
        return String::new();
    }
    let mut s = String::new();
    let _ = writeln!(
        s,
        "{GLSL_HEADING}\n\nThe same comparison in the GLSL world: a hand-written reference as published in GLSL (runtime/references/*.glsl, embedded in the binary; each cites its source) beside the generated `<filter>_eval` translated into GLSL 4.50 by `boxforge::back::translate` (naga), each behind the same hand-written compute entry point (one evaluation and one write per invocation; the ray-caster shape with {RAY_STEPS} evaluations), both compiled by the same glslang to SPIR-V and run as they are through wgpu's passthrough, on the same random points of a random 64^3 volume, checked (max |generated - reference| < {REFERENCE_TOLERANCE:.0e} of the data range, else INVALID and not timed) and timed in the same interleaved rounds as the table above. Ratio: generated ÷ reference evals/s.\n"
    );
    let _ = writeln!(s, "| generated | reference | compiled by | generated evals/s | reference evals/s | ratio median [min..max] | tie? | ray: ratio | max \\|diff\\| (of range) | source |\n|---|---|---|---|---|---|---|---|---|---|");
    for x in rows {
        let (ratio, tie) = ratio_cells(&x.ratio);
        let diff = match (x.max_abs_diff, x.rel_diff) {
            (Some(a), Some(rel)) => format!("{a:.2e} ({rel:.1e})"),
            _ => String::new(),
        };
        let status = match &x.note {
            Some(n) if x.agrees => format!(" {n}"),
            Some(n) => format!(" **{n}**"),
            None => String::new(),
        };
        let _ = writeln!(
            s,
            "| `{}` | {} (`{}`) | {} | {} | {} | {ratio}{status} | {tie} | {} | {diff} | {} |",
            x.generated,
            x.reference,
            x.entry,
            x.compiled_by.as_deref().unwrap_or("(not compiled)"),
            x.generated_evals_per_s.map(|v| format!("{v:.3e}")).unwrap_or_default(),
            x.reference_evals_per_s.map(|v| format!("{v:.3e}")).unwrap_or_default(),
            ratio_cells(&x.ray_ratio).0,
            x.citation
        );
    }
    s.push('\n');
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_references_section_splices_in_place() {
        let section = references_section(&[], &[], Some("Measured by `x`."));
        assert!(section.starts_with(REFERENCES_HEADING) && section.contains("Measured by `x`.\n\nThe generated"));
        let file = format!("# B\n\n{REFERENCES_HEADING}\n\nold table\n\n## Evaluation throughput\n\nrows\n");
        let out = splice_references(&file, &section);
        assert!(!out.contains("old table") && out.contains("(no references in this run)"), "{out}");
        assert!(out.starts_with("# B\n\n") && out.ends_with("|\n\n## Evaluation throughput\n\nrows\n"), "{out}");
        assert_eq!(splice_references(&out, &section), out, "splicing again changes nothing");
        let last = splice_references(&format!("# B\n\n{REFERENCES_HEADING}\n\nold\n"), &section);
        assert!(last.ends_with("|\n") && !last.contains("old"), "{last}");
        assert!(splice_references("# B\n", &section).contains("# B\n\n## Generated"));
    }
}
