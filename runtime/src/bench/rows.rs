//! The rows of the main report and the report itself.

use super::stats::Ratio;
use serde::Serialize;

/// Variant tags of throughput rows compared with the default module.
pub(super) const TAG_DENSE: &str = "dense form";
pub(super) const TAG_UNCHECKED: &str = "unchecked fetches";
pub(super) const TAG_LINEAR: &str = "linear fetches";

#[derive(Clone, Debug, Serialize)]
pub struct BenchRow {
    pub filter: String,
    pub layout: String,
    pub variant: String,
    /// eval, eval_grad, central_differences, render_ml_256, ...
    pub kind: String,
    /// Median over rounds.
    pub evals_per_s: Option<f64>,
    /// Median over rounds.
    pub ms_per_frame: Option<f64>,
    /// Median of the per-round ratios (see `ratio`).
    pub ratio_to_baseline: Option<f64>,
    /// Per-round ratio statistics: median, min, max, rounds, tie.
    pub ratio: Option<Ratio>,
    pub baseline: Option<String>,
    pub fetches: Option<usize>,
    pub ops: Option<usize>,
    pub bytes: Option<usize>,
    /// Linear fetches: max |value - the exact-load baseline's value| on the
    /// timed points, as a fraction of the data range (this adapter's filtering).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub max_rel_diff_to_baseline: Option<f64>,
}

impl BenchRow {
    /// A rendering row (embedded layout, ms/frame, optional ratio to a baseline).
    pub fn render(
        filter: &str,
        kind: &str,
        variant: String,
        ms: f64,
        ratio: Option<Ratio>,
        baseline: Option<String>,
    ) -> BenchRow {
        BenchRow {
            filter: filter.into(),
            layout: "embedded".into(),
            variant,
            kind: kind.into(),
            evals_per_s: None,
            ms_per_frame: Some(ms),
            ratio_to_baseline: ratio.map(|r| r.median),
            ratio,
            baseline,
            fetches: None,
            ops: None,
            bytes: None,
            max_rel_diff_to_baseline: None,
        }
    }
}

/// The generated evaluation timed beside a hand-written one.
#[derive(Clone, Debug, Serialize)]
pub struct ReferenceRow {
    pub filter: String,
    pub generated: String,
    pub reference: String,
    pub entry: String,
    pub citation: String,
    pub generated_fetches: usize,
    pub reference_fetches: Option<usize>,
    pub generated_ops: usize,
    pub reference_ops: usize,
    /// Medians over rounds (None when not timed).
    pub generated_evals_per_s: Option<f64>,
    pub reference_evals_per_s: Option<f64>,
    /// generated ÷ reference, per round.
    pub ratio: Option<Ratio>,
    pub points: usize,
    /// max |generated - reference| over the points.
    pub max_abs_diff: Option<f64>,
    pub data_range: f64,
    /// max_abs_diff / data_range.
    pub rel_diff: Option<f64>,
    /// The check passed (rel_diff < REFERENCE_TOLERANCE); a comparison that
    /// failed it (or was skipped) is not timed.
    pub agrees: bool,
    /// Why the comparison is invalid or was skipped.
    pub note: Option<String>,
    /// The generated eval cut after its fetches (same locate, same loads,
    /// the mean of the samples) ÷ the reference, in the same rounds: the
    /// most any evaluation with these loads could reach.
    pub loads_only_ratio: Option<Ratio>,
    /// generated ÷ reference in the ray-caster kernel shape
    /// (`RAY_STEPS` (16) evaluations per invocation along a
    /// short path, one write), timed in the same rounds.
    pub ray_ratio: Option<Ratio>,
    /// The loads-only cut ÷ the reference, ray-caster shape.
    pub ray_loads_only_ratio: Option<Ratio>,
}

#[derive(Clone, Debug, Serialize)]
pub struct QualityRow {
    pub filter: String,
    pub lattice: String,
    pub samples: usize,
    pub budget: String,
    pub prefiltered: bool,
    pub rms_error: f64,
    pub max_error: f64,
    /// Mean angle (degrees) between the spline's analytic gradient and the
    /// analytic Marschner-Lobb gradient, where |grad| is not tiny.
    pub gradient_angle_deg: f64,
}

#[derive(Clone, Debug, Serialize)]
pub struct ConvergenceRow {
    pub filter: String,
    pub approximation_order: usize,
    pub edges: Vec<usize>,
    pub rms_errors: Vec<f64>,
    /// Order estimated from the last two resolutions.
    pub measured_order: f64,
}

#[derive(Clone, Debug, Serialize)]
pub struct BenchReport {
    pub machine: String,
    pub adapter: String,
    pub timing: String,
    /// Interleaved timing rounds per comparison.
    pub rounds: usize,
    /// Generated vs hand-written (built-in references and --wgsl).
    pub references: Vec<ReferenceRow>,
    /// The same in GLSL: published GLSL beside the generated GLSL, both by glslang.
    pub glsl_references: Vec<GlslRivalRow>,
    pub rows: Vec<BenchRow>,
    pub gradient: Vec<GradientRow>,
    pub quality: Vec<QualityRow>,
    pub convergence: Vec<ConvergenceRow>,
    /// False in the snapshots [`run_with`](fn@super::run_with) hands out while it measures.
    pub complete: bool,
}

#[derive(Clone, Debug, Serialize)]
pub struct GradientRow {
    pub filter: String,
    pub analytic_evals_per_s: f64,
    pub central_evals_per_s: f64,
    /// Median of the per-round ratios.
    pub speedup: f64,
    pub speedup_ratio: Ratio,
    pub analytic_angle_deg: f64,
    pub central_angle_deg: f64,
}

/// The generated GLSL timed beside a hand-written GLSL evaluation.
#[derive(Clone, Debug, Serialize)]
pub struct GlslRivalRow {
    pub filter: String,
    /// The generated function and how it became GLSL.
    pub generated: String,
    pub reference: String,
    pub entry: String,
    pub citation: String,
    /// glslang's name and version (both sides), when it ran.
    pub compiled_by: Option<String>,
    pub points: usize,
    /// Medians over rounds (None when not timed).
    pub generated_evals_per_s: Option<f64>,
    pub reference_evals_per_s: Option<f64>,
    /// generated ÷ reference, per round, one evaluation per invocation.
    pub ratio: Option<Ratio>,
    /// generated ÷ reference in the ray-caster shape (`RAY_STEPS` (16)
    /// evaluations per invocation), timed in the same rounds.
    pub ray_ratio: Option<Ratio>,
    pub max_abs_diff: Option<f64>,
    pub data_range: f64,
    pub rel_diff: Option<f64>,
    /// The check passed; a row that failed it (or was skipped) is not timed.
    pub agrees: bool,
    /// Why the row is invalid or was skipped.
    pub note: Option<String>,
}
