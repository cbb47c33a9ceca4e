//! Hand-written reference shaders (runtime/references/), embedded in the
//! binary, each timed beside the generated evaluation of its filter.

/// One hand-written evaluation function, appended to the generated embedded
/// module of `like` (it may call `<like>_fetch` and use `<like>_volume`).
#[derive(Clone, Debug)]
pub struct Reference {
    /// Short name for tables.
    pub name: String,
    /// The filter whose generated module it is appended to, and compared with.
    pub like: String,
    /// `fn entry(p: vec3<f32>) -> f32`.
    pub entry: String,
    /// Where it comes from (paper, authors, year).
    pub citation: String,
    /// The WGSL source (functions, and a `ref_linear` sampler binding if it filters).
    pub source: String,
}

pub const KIM_LEE_BCC7: &str = include_str!("../references/kim_lee_bcc7.wgsl");
/// Kim 2013's fcc6 (Figure 5's branch-free locate and 19 fetches, BB form,
/// de Casteljau); the BB tables' provenance is in the file's header.
pub const KIM_FCC6: &str = include_str!("../references/kim_fcc6.wgsl");
pub const SEPARABLE_TRICUBIC: &str = include_str!("../references/separable_tricubic.wgsl");
/// The tricubic value, gradient and Hessian by separable weights (timed by
/// `boxforge bench --hessian` beside `cc_tricubic_eval_hessian`).
pub const SEPARABLE_TRICUBIC_HESSIAN: &str = include_str!("../references/separable_tricubic_hessian.wgsl");
/// Kim's bcc7 value, gradient and Hessian (one quartic, three cubic and six
/// quadratic formulas, cg-uos/bcc7's bcc7_raycast_curvature.frag), our WGSL
/// (timed by `boxforge bench --hessian` beside `bcc7_eval_hessian`).
pub const KIM_BCC7_HESSIAN: &str = include_str!("../references/kim_bcc7_hessian.wgsl");
/// Kim & Kim 2023's cc6 value, gradient and Hessian (cg-uos/cc6's
/// cc6_raycast_curvature.frag), our WGSL (timed by `boxforge bench
/// --hessian` beside `cc6_eval_hessian`).
pub const KIM_KIM_CC6_HESSIAN: &str = include_str!("../references/kim_kim_cc6_hessian.wgsl");
pub const SIGG_HADWIGER_TRICUBIC: &str = include_str!("../references/sigg_hadwiger_tricubic.wgsl");
/// Mattausch et al.'s bilinear and bilinear-plus-spatial BCC schemes, on the
/// generated `bcc_linear` module's fetch (not box splines of the catalog:
/// see the file). Checked against an independent CPU implementation in
/// runtime/tests/mattausch_references.rs; no generated filter equals them,
/// so they are not in [`builtin`].
pub const MATTAUSCH_BILINEAR: &str = include_str!("../references/mattausch_bilinear.wgsl");

/// The built-in references.
pub fn builtin() -> Vec<Reference> {
    let r = |name: &str, like: &str, entry: &str, citation: &str, source: &str| Reference {
        name: name.into(),
        like: like.into(),
        entry: entry.into(),
        citation: citation.into(),
        source: source.into(),
    };
    vec![
        r(
            "Kim & Lee bcc7",
            "bcc7",
            "kim_lee_bcc7",
            "M. Kim & Y. Lee 2012 / M. Kim 2013: branch-free GLSL (Fig. 7) + simplified symbolic formula",
            KIM_LEE_BCC7,
        ),
        r(
            "Kim fcc6",
            "fcc6",
            "kim_fcc6",
            "M. Kim 2013: branch-free GLSL (Fig. 5, 19 fetches) + BB form and de Casteljau",
            KIM_FCC6,
        ),
        r(
            "separable tricubic",
            "cc_tricubic",
            "separable_tricubic",
            "uniform cubic B-spline weights, 3 x 4 weights, 64 texel loads",
            SEPARABLE_TRICUBIC,
        ),
        r(
            "Sigg & Hadwiger tricubic",
            "cc_tricubic",
            "sigg_hadwiger_tricubic",
            "C. Sigg & M. Hadwiger 2005, GPU Gems 2 ch. 20: 8 trilinear fetches",
            SIGG_HADWIGER_TRICUBIC,
        ),
    ]
}

/// Does the source need the linear sampler (bind group 1) and a filterable texture?
pub fn uses_sampler(source: &str) -> bool {
    source.contains("var ref_linear")
}

/// The source without `//` comment lines (for op counting).
pub fn code_only(source: &str) -> String {
    source.lines().filter(|l| !l.trim_start().starts_with("//")).collect::<Vec<_>>().join("\n")
}

/// The body (between the outer braces) of every `fn` in the source, by name.
pub fn function_bodies(source: &str) -> std::collections::HashMap<String, String> {
    let code = code_only(source);
    let mut out = std::collections::HashMap::new();
    let mut rest = code.as_str();
    while let Some(at) = rest.find("fn ") {
        let after = &rest[at + 3..];
        let name: String = after.chars().take_while(|c| c.is_alphanumeric() || *c == '_').collect();
        let Some(open) = after.find('{') else { break };
        let mut depth = 0usize;
        let mut end = after.len();
        for (i, ch) in after[open..].char_indices() {
            match ch {
                '{' => depth += 1,
                '}' => {
                    depth -= 1;
                    if depth == 0 {
                        end = open + i;
                        break;
                    }
                }
                _ => {}
            }
        }
        out.insert(name, after[open + 1..end].to_string());
        rest = &after[end.min(after.len())..];
    }
    out
}

/// Ops of one body: `boxforge::emit::count_ops`, plus 7 per `dot(` (a vec4
/// dot product: 4 multiplies and 3 adds, which count_ops does not see).
fn body_ops(body: &str) -> usize {
    boxforge::emit::count_ops(body) + 7 * body.matches("dot(").count()
}

/// Arithmetic ops per evaluation of the reference `entry`: its body's ops plus,
/// per call site (naga's call tree), the ops of the reference's own helper
/// functions it calls (calls into the generated module, such as
/// `<f>_fetch`, count nothing: the generated side's count excludes them too).
pub fn ops(module_source: &str, reference_source: &str, entry: &str) -> usize {
    let bodies = function_bodies(reference_source);
    let report = boxforge::validate::validate_wgsl(module_source, entry);
    fn walk(
        name: &str,
        bodies: &std::collections::HashMap<String, String>,
        report: &boxforge::validate::ValidationReport,
        depth: usize,
    ) -> usize {
        let Some(body) = bodies.get(name) else { return 0 };
        let own = body_ops(body);
        if depth > 16 {
            return own;
        }
        let calls = report.function(name).map(|f| f.calls.clone()).unwrap_or_default();
        own + calls.iter().map(|c| walk(c, bodies, report, depth + 1)).sum::<usize>()
    }
    walk(entry, &bodies, &report, 0)
}

/// Fetches per evaluation: texel loads over the call tree of `entry` (naga),
/// plus filtered fetches (`textureSampleLevel` calls in the source).
pub fn fetches(module_source: &str, reference_source: &str, entry: &str) -> Option<usize> {
    let report = boxforge::validate::validate_wgsl(module_source, entry);
    let loads = report.function(entry)?.total_loads;
    Some(loads + code_only(reference_source).matches("textureSampleLevel(").count())
}
