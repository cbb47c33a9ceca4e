//! WGSL emission: turns a [`Plan`] and the exact reference forms into a
//! module with `<f>_fetch`, `<f>_eval`, `<f>_eval_grad`, and the prefilter
//! and min/max kernels. Skeletons are minijinja templates (`templates/`);
//! expression code is written by the small [`Body`] writer below.
//!
//! The `fast` variant is straight-line code: folding, sorting networks and
//! plane tests drive `select`; fetch positions walk axis-aligned steps. The
//! `naive` variant computes the same mathematics with `if`, loops and lookup
//! tables, so the benefit can be measured (and the branch-free check can fail).

use crate::bb::BbForm;
use crate::derive::Derivation;
use crate::error::{Error, Result};
use crate::exact::{binomial, Q};
use crate::lattice::Lattice;
use crate::linalg::{inverse, sub_q, IVec, QVec};
use crate::plan::{Candidate, Locate, Plan};
use crate::poly::Poly;
use crate::symmetry::SignedPerm;
use serde::Serialize;
use std::fmt::Write;

/// Storage layout of the samples.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Layout {
    /// Cartesian texture with the lattice embedded (|det G| texels per sample).
    Embedded,
    /// One dense array per coset of 2Z^s in a storage buffer (one word per sample).
    Packed,
}

/// Code shape.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Variant {
    /// Branch-free, table-free straight-line code.
    Fast,
    /// The same mathematics with branches, loops and lookup tables.
    Naive,
}

impl Layout {
    pub fn name(self) -> &'static str {
        match self {
            Layout::Embedded => "embedded",
            Layout::Packed => "packed",
        }
    }
    pub fn parse(s: &str) -> Option<Layout> {
        match s {
            "embedded" => Some(Layout::Embedded),
            "packed" => Some(Layout::Packed),
            _ => None,
        }
    }
}

impl Variant {
    pub fn name(self) -> &'static str {
        match self {
            Variant::Fast => "fast",
            Variant::Naive => "naive",
        }
    }
    pub fn parse(s: &str) -> Option<Variant> {
        match s {
            "fast" => Some(Variant::Fast),
            "naive" => Some(Variant::Naive),
            _ => None,
        }
    }
}

#[derive(Clone, Debug)]
pub struct EmitOptions {
    pub layout: Layout,
    pub variant: Variant,
    /// Bind group and first binding of the samples.
    pub group: u32,
    pub binding: u32,
    /// Include the prefilter and min/max compute kernels.
    pub kernels: bool,
    /// The command named in the header.
    pub command: String,
}

impl Default for EmitOptions {
    fn default() -> Self {
        EmitOptions {
            layout: Layout::Embedded,
            variant: Variant::Fast,
            group: 0,
            binding: 0,
            kernels: true,
            command: "boxforge generate".into(),
        }
    }
}

/// Counts reported per emitted module.
#[derive(Clone, Debug, Serialize)]
pub struct EmitStats {
    pub layout: Layout,
    pub variant: Variant,
    pub locate: String,
    pub candidates: usize,
    pub fetches_per_eval: usize,
    pub vector_adds: usize,
    pub matvec_adds: usize,
    /// Arithmetic operators, comparisons, selects and builtin calls in the
    /// source of `eval` / `eval_grad` (a static count, not a timing).
    pub ops_eval: usize,
    pub ops_eval_grad: usize,
}

#[derive(Clone, Debug)]
pub struct Emitted {
    pub file_name: String,
    pub source: String,
    pub stats: EmitStats,
}

/// `<filter>.<layout>.wgsl` or `<filter>.<layout>.naive.wgsl`.
pub fn file_name(filter: &str, layout: Layout, variant: Variant) -> String {
    match variant {
        Variant::Fast => format!("{filter}.{}.wgsl", layout.name()),
        Variant::Naive => format!("{filter}.{}.naive.wgsl", layout.name()),
    }
}

const AXES: [&str; 4] = ["x", "y", "z", "w"];

/// An f32 literal for an exact rational (shortest round-trip form).
pub fn lit(q: &Q) -> String {
    flit(q.to_f64() as f32)
}

fn flit(v: f32) -> String {
    let s = format!("{v:?}");
    if s.contains('.') || s.contains('e') || s.contains("inf") || s.contains("NaN") {
        s
    } else {
        format!("{s}.0")
    }
}

/// Straight-line code with fresh `let` names.
struct Body {
    text: String,
    next: usize,
    indent: usize,
}

impl Body {
    fn new() -> Body {
        Body { text: String::new(), next: 0, indent: 1 }
    }
    fn line(&mut self, s: &str) {
        for _ in 0..self.indent {
            self.text.push_str("    ");
        }
        self.text.push_str(s);
        self.text.push('\n');
    }
    fn bind(&mut self, prefix: &str, expr: &str) -> String {
        let name = format!("{prefix}_{}", self.next);
        self.next += 1;
        self.line(&format!("let {name} = {expr};"));
        name
    }
}

/// Shapes of vectors for a dimension.
struct Shapes {
    s: usize,
    vecf: String,
    veci: String,
}

impl Shapes {
    fn new(s: usize) -> Shapes {
        Shapes { s, vecf: format!("vec{s}<f32>"), veci: format!("vec{s}<i32>") }
    }
    fn ivec(&self, v: &[i64]) -> String {
        format!("{}({})", self.veci, v.iter().map(|x| x.to_string()).collect::<Vec<_>>().join(", "))
    }
    fn fvec(&self, v: &[String]) -> String {
        format!("{}({})", self.vecf, v.join(", "))
    }
    /// R v for a signed permutation R and a vector expression `v`.
    fn perm_apply(&self, r: &SignedPerm, v: &str) -> String {
        let comps: Vec<String> = r
            .iter()
            .map(|row| {
                let (j, sgn) = row.iter().enumerate().find(|(_, x)| **x != 0).map(|(j, x)| (j, *x)).unwrap();
                if sgn > 0 {
                    format!("{v}.{}", AXES[j])
                } else {
                    format!("-{v}.{}", AXES[j])
                }
            })
            .collect();
        self.fvec(&comps)
    }
}

/// sum of coefficient * term, skipping zeros and writing +-1 without a product.
fn linear_combination(terms: &[(Q, String)]) -> String {
    let mut out = String::new();
    for (c, t) in terms {
        if c.is_zero() {
            continue;
        }
        let mag = c.abs();
        let piece = if mag.is_one() { t.clone() } else { format!("{} * {t}", lit(&mag)) };
        if out.is_empty() {
            out = if c.is_negative() { format!("-{piece}") } else { piece };
        } else if c.is_negative() {
            let _ = write!(out, " - {piece}");
        } else {
            let _ = write!(out, " + {piece}");
        }
    }
    if out.is_empty() {
        "0.0".to_string()
    } else {
        out
    }
}

/// `n . w <= b` with a small tolerance so neighbouring cells overlap (the
/// last satisfied candidate wins; neighbours agree on shared faces).
fn plane_test(sh: &Shapes, normal: &[Q], bound: &Q, w: &str) -> String {
    let terms: Vec<(Q, String)> = (0..sh.s).map(|i| (normal[i].clone(), format!("{w}.{}", AXES[i]))).collect();
    format!("({} <= {} + 1e-6)", linear_combination(&terms), lit(bound))
}

/// Coefficients of every monomial (power form) or BB index, as exact weights
/// of the stencil samples: (per coefficient, per stencil index) weights.
enum Form<'a> {
    Bb(&'a BbForm),
    Power(&'a [Poly]),
}

/// Emits the coefficient lets for reference `r`, given the sample names per
/// stencil index. Returns their names (in form order).
fn emit_coefficients(body: &mut Body, weights: &[Vec<Q>], samples: &[String], prefix: &str) -> Vec<String> {
    weights
        .iter()
        .map(|w| {
            let terms: Vec<(Q, String)> = w.iter().cloned().zip(samples.iter().cloned()).collect();
            body.bind(prefix, &linear_combination(&terms))
        })
        .collect()
}

/// Per-coefficient weights of a form: rows = coefficients, columns = stencil.
fn form_weights(form: &Form) -> (Vec<Vec<u32>>, Vec<Vec<Q>>) {
    match form {
        Form::Bb(bb) => (bb.indices.clone(), bb.weights.clone()),
        Form::Power(polys) => {
            let exps = polys[0].basis.exps.clone();
            let rows: Vec<Vec<Q>> =
                (0..exps.len()).map(|e| polys.iter().map(|p| p.coeffs[e].clone()).collect()).collect();
            // Drop monomials that are zero for every sample.
            let keep: Vec<usize> = (0..exps.len()).filter(|&e| rows[e].iter().any(|c| !c.is_zero())).collect();
            (keep.iter().map(|&e| exps[e].clone()).collect(), keep.iter().map(|&e| rows[e].clone()).collect())
        }
    }
}

/// Evaluates a form at local coordinates `u` from its coefficient names.
/// Returns (value, gradient in u as a vector expression or None).
fn emit_form_eval(
    body: &mut Body,
    sh: &Shapes,
    form: &Form,
    indices: &[Vec<u32>],
    coeffs: &[String],
    u: &str,
    grad: bool,
    degree: usize,
) -> (String, Option<String>) {
    let s = sh.s;
    match form {
        Form::Bb(bb) => {
            // Barycentric coordinates: lambda_i = affine(u).
            let v0 = &bb.vertices[0];
            let t: Vec<QVec> = (0..s).map(|j| (1..=s).map(|i| &bb.vertices[i][j] - &v0[j]).collect()).collect();
            let tinv = inverse(&t).expect("simplex");
            // lambda_i (i>=1) = sum_j tinv[i-1][j] (u_j - v0_j)
            let mut grads: Vec<QVec> = vec![vec![Q::zero(); s]; s + 1];
            let mut consts: Vec<Q> = vec![Q::zero(); s + 1];
            for i in 1..=s {
                grads[i] = tinv[i - 1].clone();
                consts[i] = -crate::linalg::dot_q(&tinv[i - 1], v0);
            }
            grads[0] = (0..s).map(|j| -(1..=s).map(|i| grads[i][j].clone()).sum::<Q>()).collect();
            consts[0] = Q::one() - (1..=s).map(|i| consts[i].clone()).sum::<Q>();
            let lam: Vec<String> = (0..=s)
                .map(|i| {
                    let mut terms: Vec<(Q, String)> =
                        (0..s).map(|j| (grads[i][j].clone(), format!("{u}.{}", AXES[j]))).collect();
                    if !consts[i].is_zero() {
                        terms.push((consts[i].clone(), "1.0".into()));
                    }
                    body.bind("l", &linear_combination(&terms))
                })
                .collect();
            if degree == 0 {
                return (coeffs[0].clone(), grad.then(|| format!("{}(0.0)", sh.vecf)));
            }
            // de Casteljau down to degree 1.
            let mut level: Vec<(Vec<u32>, String)> = indices.iter().cloned().zip(coeffs.iter().cloned()).collect();
            for l in (1..degree).rev() {
                let lower: Vec<Vec<u32>> = crate::poly::Monomials::get(s + 1, l)
                    .exps
                    .iter()
                    .filter(|e| e.iter().sum::<u32>() as usize == l)
                    .cloned()
                    .collect();
                let mut next = Vec::new();
                for beta in lower {
                    let parts: Vec<String> = (0..=s)
                        .map(|i| {
                            let mut a = beta.clone();
                            a[i] += 1;
                            let name = &level.iter().find(|(e, _)| *e == a).unwrap().1;
                            format!("{} * {name}", lam[i])
                        })
                        .collect();
                    let n = body.bind("dc", &parts.join(" + "));
                    next.push((beta, n));
                }
                level = next;
            }
            let unit = |i: usize| -> String {
                let mut a = vec![0u32; s + 1];
                a[i] = 1;
                level.iter().find(|(e, _)| *e == a).unwrap().1.clone()
            };
            let value =
                body.bind("v", &(0..=s).map(|i| format!("{} * {}", lam[i], unit(i))).collect::<Vec<_>>().join(" + "));
            let g = grad.then(|| {
                let comps: Vec<String> = (0..s)
                    .map(|j| {
                        let terms: Vec<(Q, String)> = (0..=s).map(|i| (grads[i][j].clone(), unit(i))).collect();
                        format!("({})", linear_combination(&terms))
                    })
                    .collect();
                body.bind("g", &format!("{} * {}", flit(degree as f32), sh.fvec(&comps)))
            });
            (value, g)
        }
        Form::Power(_) => {
            // Powers of each coordinate, then monomials.
            let maxdeg = indices.iter().flat_map(|e| e.iter()).copied().max().unwrap_or(0) as usize;
            let mut pows: Vec<Vec<String>> = Vec::new();
            for j in 0..s {
                let mut p = vec!["1.0".to_string(), format!("{u}.{}", AXES[j])];
                for k in 2..=maxdeg {
                    let n = body.bind("pw", &format!("{} * {u}.{}", p[k - 1], AXES[j]));
                    p.push(n);
                }
                pows.push(p);
            }
            let mono = |e: &[u32], skip: Option<usize>| -> Option<String> {
                let mut f: Vec<String> = Vec::new();
                for j in 0..s {
                    let k = if Some(j) == skip { e[j] as i64 - 1 } else { e[j] as i64 };
                    if k < 0 {
                        return None;
                    }
                    if k > 0 {
                        f.push(pows[j][k as usize].clone());
                    }
                }
                Some(if f.is_empty() { "1.0".to_string() } else { f.join(" * ") })
            };
            let terms: Vec<String> = indices
                .iter()
                .zip(coeffs)
                .map(|(e, c)| {
                    let m = mono(e, None).unwrap();
                    if m == "1.0" {
                        c.clone()
                    } else {
                        format!("{c} * {m}")
                    }
                })
                .collect();
            let value = body.bind("v", &sum_or_zero(&terms));
            let g = grad.then(|| {
                let comps: Vec<String> = (0..s)
                    .map(|j| {
                        let t: Vec<String> = indices
                            .iter()
                            .zip(coeffs)
                            .filter_map(|(e, c)| {
                                let m = mono(e, Some(j))?;
                                let k = e[j];
                                Some(if k == 1 {
                                    if m == "1.0" {
                                        c.clone()
                                    } else {
                                        format!("{c} * {m}")
                                    }
                                } else if m == "1.0" {
                                    format!("{} * {c}", flit(k as f32))
                                } else {
                                    format!("{} * {c} * {m}", flit(k as f32))
                                })
                            })
                            .collect();
                        format!("({})", sum_or_zero(&t))
                    })
                    .collect();
                body.bind("g", &sh.fvec(&comps))
            });
            (value, g)
        }
    }
}

fn sum_or_zero(terms: &[String]) -> String {
    if terms.is_empty() {
        "0.0".into()
    } else {
        terms.join(" + ")
    }
}

/// The frame: base (veci), columns of M (veci names), w (vecf), class (i32 or None).
struct Frame {
    base: String,
    cols: Vec<String>,
    w: String,
    class: Option<String>,
}

fn emit_frame(body: &mut Body, sh: &Shapes, plan: &Plan, name: &str, naive: bool) -> Frame {
    let s = sh.s;
    match plan.locate {
        Locate::Fold { sort } => {
            let c = body.bind("c", "2.0 * round(p * 0.5)");
            let d = body.bind("d", &format!("p - {c}"));
            let sg = body.bind("sg", &format!("select({}(-1), {}(1), {d} >= {}(0.0))", sh.veci, sh.veci, sh.vecf));
            let base = body.bind("base", &format!("{}({c})", sh.veci));
            let mut w = body.bind("w", &format!("abs({d})"));
            let mut cols: Vec<String> = (0..s)
                .map(|i| {
                    let comps: Vec<String> =
                        (0..s).map(|j| if i == j { format!("{sg}.{}", AXES[j]) } else { "0".into() }).collect();
                    body.bind("m", &format!("{}({})", sh.veci, comps.join(", ")))
                })
                .collect();
            if sort {
                let pairs: Vec<(usize, usize)> = match s {
                    2 => vec![(0, 1)],
                    3 => vec![(0, 1), (1, 2), (0, 1)],
                    _ => (0..s).flat_map(|i| (0..s - 1 - i).map(|j| (j, j + 1))).collect(),
                };
                for (i, j) in pairs {
                    let mut swz: Vec<&str> = AXES[..s].to_vec();
                    swz.swap(i, j);
                    let swz: String = swz.concat();
                    if naive {
                        body.line(&format!("if ({w}.{} < {w}.{}) {{", AXES[i], AXES[j]));
                        body.line(&format!("    {w} = {w}.{swz};"));
                        body.line(&format!("    let t = {};", cols[i]));
                        body.line(&format!("    {} = {};", cols[i], cols[j]));
                        body.line(&format!("    {} = t;", cols[j]));
                        body.line("}");
                    } else {
                        let sw = body.bind("sw", &format!("{w}.{} < {w}.{}", AXES[i], AXES[j]));
                        let nw = body.bind("w", &format!("select({w}, {w}.{swz}, {sw})"));
                        let ci = body.bind("m", &format!("select({}, {}, {sw})", cols[i], cols[j]));
                        let cj = body.bind("m", &format!("select({}, {}, {sw})", cols[j], cols[i]));
                        w = nw;
                        cols[i] = ci;
                        cols[j] = cj;
                    }
                }
            }
            Frame { base, cols, w, class: None }
        }
        Locate::Generic => {
            let o: Vec<String> = plan.grid_offset.iter().map(lit).collect();
            let z = body.bind("z", &format!("{}(floor(p - {}))", sh.veci, sh.fvec(&o)));
            // Reduce z modulo L with the Hermite basis (column i is zero above row i).
            let mut r = z.clone();
            for i in 0..s {
                let h = plan.hermite[i][i];
                if h == 1 && (i + 1..s).all(|k| plan.hermite[i][k] == 0) {
                    // subtracting floor(r_i) * e_i just zeroes the coordinate
                }
                let q = body.bind("q", &format!("{name}_floor_div({r}.{}, {h})", AXES[i]));
                r = body.bind("r", &format!("{r} - {q} * {}", sh.ivec(&plan.hermite[i])));
            }
            let mut cls = body.bind("cls", "0");
            let mut rep = body.bind("rep", &sh.ivec(&plan.classes[0]));
            for (k, key) in plan.class_keys.iter().enumerate().skip(1) {
                let hit = body.bind("hit", &format!("all({r} == {})", sh.ivec(key)));
                if naive {
                    body.line(&format!("if ({hit}) {{ {cls} = {k}; {rep} = {}; }}", sh.ivec(&plan.classes[k])));
                } else {
                    cls = body.bind("cls", &format!("select({cls}, {k}, {hit})"));
                    rep = body.bind("rep", &format!("select({rep}, {}, {hit})", sh.ivec(&plan.classes[k])));
                }
            }
            let base = body.bind("base", &format!("{z} - {rep}"));
            let w = body.bind("w", &format!("p - {}({base})", sh.vecf));
            let cols: Vec<String> = (0..s)
                .map(|i| {
                    let mut e = vec![0; s];
                    e[i] = 1;
                    sh.ivec(&e)
                })
                .collect();
            Frame { base, cols, w, class: Some(cls) }
        }
    }
}

/// Index of the chosen candidate (an i32 expression; "0" when only one).
fn emit_candidate_choice(body: &mut Body, sh: &Shapes, plan: &Plan, frame: &Frame, naive: bool) -> String {
    if plan.candidates.len() == 1 && frame.class.is_none() {
        return "0".into();
    }
    let tests = |c: &Candidate| -> String {
        let mut t: Vec<String> = c.tests.iter().map(|h| plane_test(sh, &h.normal, &h.bound, &frame.w)).collect();
        if let Some(cls) = &frame.class {
            t.push(format!("({cls} == {})", c.class));
        }
        if t.is_empty() {
            "true".into()
        } else {
            t.join(" & ")
        }
    };
    if naive {
        body.line("var ci = 0;");
        for (i, c) in plan.candidates.iter().enumerate().skip(1) {
            body.line(&format!("if ({}) {{ ci = {i}; }}", tests(c).replace(" & ", " && ")));
        }
        return "ci".into();
    }
    let mut ci = "0".to_string();
    for (i, c) in plan.candidates.iter().enumerate().skip(1) {
        let inside = body.bind("in", &tests(c));
        ci = body.bind("ci", &format!("select({ci}, {i}, {inside})"));
    }
    ci
}

/// select chain over candidates: values[i] when ci == i.
fn select_by_candidate(body: &mut Body, ci: &str, values: &[String], prefix: &str) -> String {
    if values.len() == 1 || values.iter().all(|v| *v == values[0]) {
        return values[0].clone();
    }
    let mut acc = values[0].clone();
    for (i, v) in values.iter().enumerate().skip(1) {
        if *v == acc {
            continue;
        }
        acc = body.bind(prefix, &format!("select({acc}, {v}, {ci} == {i})"));
    }
    acc
}

/// M q for a constant integer vector q.
fn frame_times(sh: &Shapes, cols: &[String], q: &[i64]) -> Option<String> {
    let parts: Vec<String> = (0..sh.s)
        .filter(|&i| q[i] != 0)
        .map(|i| match q[i] {
            1 => cols[i].clone(),
            -1 => format!("-{}", cols[i]),
            k => format!("{k} * {}", cols[i]),
        })
        .collect();
    (!parts.is_empty()).then(|| parts.join(" + "))
}

/// Emits fetches for every slot; returns the sample names per slot.
fn emit_fetches(body: &mut Body, sh: &Shapes, plan: &Plan, frame: &Frame, ci: &str, name: &str) -> Vec<String> {
    let nslots = plan.fetches();
    let mut out = Vec::new();
    if plan.candidates.len() == 1 {
        // Axis-aligned walk: each step adds pre-scaled frame columns.
        let offs = &plan.candidates[0].offsets;
        let mut scaled: std::collections::BTreeMap<(usize, i64), String> = std::collections::BTreeMap::new();
        let mut pos = String::new();
        let mut prev = vec![0i64; sh.s];
        for (k, q) in offs.iter().enumerate() {
            let delta: IVec = q.iter().zip(&prev).map(|(a, b)| a - b).collect();
            let mut parts = Vec::new();
            for i in 0..sh.s {
                if delta[i] == 0 {
                    continue;
                }
                let col = match delta[i] {
                    1 => frame.cols[i].clone(),
                    -1 => format!("-{}", frame.cols[i]),
                    dlt => scaled
                        .entry((i, dlt))
                        .or_insert_with(|| body.bind("col", &format!("{dlt} * {}", frame.cols[i])))
                        .clone(),
                };
                parts.push(col);
            }
            let start = if k == 0 { frame.base.clone() } else { pos.clone() };
            pos = if parts.is_empty() {
                start
            } else {
                let expr = parts.iter().fold(start, |acc, p| {
                    if let Some(rest) = p.strip_prefix('-') {
                        format!("{acc} - {rest}")
                    } else {
                        format!("{acc} + {p}")
                    }
                });
                body.bind("j", &expr)
            };
            prev = q.clone();
            out.push(body.bind("f", &format!("{name}_fetch({pos})")));
        }
        return out;
    }
    for slot in 0..nslots {
        let qs: Vec<String> = plan.candidates.iter().map(|c| sh.ivec(&c.offsets[slot])).collect();
        let q = select_by_candidate(body, ci, &qs, "q");
        let parts: Vec<String> = (0..sh.s).map(|i| format!("{} * {q}.{}", frame.cols[i], AXES[i])).collect();
        let j = body.bind("j", &format!("{} + {}", frame.base, parts.join(" + ")));
        out.push(body.bind("f", &format!("{name}_fetch({j})")));
    }
    out
}

/// Local coordinates of reference r for each candidate of it: R w + t - o - corner.
fn local_coords(sh: &Shapes, d: &Derivation, plan: &Plan, c: &Candidate, w: &str) -> String {
    let r = &d.references[c.reference];
    let shift: QVec =
        (0..sh.s).map(|i| &(&Q::int(c.translation[i]) - &plan.grid_offset[i]) - &Q::int(r.corner[i])).collect();
    let rw = sh.perm_apply(&c.rotation, w);
    if shift.iter().all(|x| x.is_zero()) {
        rw
    } else {
        format!("{rw} + {}", sh.fvec(&shift.iter().map(lit).collect::<Vec<_>>()))
    }
}

/// The body of eval (grad = false) or eval_grad.
fn emit_eval_body(d: &Derivation, plan: &Plan, sh: &Shapes, name: &str, grad: bool, naive: bool) -> String {
    let mut body = Body::new();
    let frame =
        if naive { emit_frame_naive(&mut body, sh, plan, name) } else { emit_frame(&mut body, sh, plan, name, false) };
    let ci = emit_candidate_choice(&mut body, sh, plan, &frame, naive);
    let samples_by_slot = if naive {
        emit_fetches_naive(&mut body, sh, plan, &frame, &ci, name)
    } else {
        emit_fetches(&mut body, sh, plan, &frame, &ci, name)
    };
    let mut values: Vec<(usize, String, Option<String>)> = Vec::new();
    for r in plan.used_references() {
        let forms = d.forms(r);
        let form = match &forms.bb {
            Some(bb) => Form::Bb(bb),
            None => Form::Power(&forms.polys),
        };
        let (indices, weights) = form_weights(&form);
        // samples per stencil index, via the slot mapping.
        let nst = d.references[r].stencil.len();
        let mut per_k = vec![String::from("0.0"); nst];
        for (slot, k) in plan.slots[r].iter().enumerate() {
            if let Some(k) = k {
                per_k[*k] = samples_by_slot[slot].clone();
            }
        }
        let coeffs = if naive {
            emit_coefficients_naive(&mut body, &weights, &per_k, &format!("{name}_W{r}"))
        } else {
            emit_coefficients(&mut body, &weights, &per_k, "b")
        };
        let cands: Vec<(usize, &Candidate)> =
            plan.candidates.iter().enumerate().filter(|(_, c)| c.reference == r).collect();
        let us: Vec<String> = plan
            .candidates
            .iter()
            .map(|c| if c.reference == r { local_coords(sh, d, plan, c, &frame.w) } else { String::new() })
            .collect();
        let u = if cands.len() == 1 {
            body.bind("u", &us[cands[0].0])
        } else {
            let first = body.bind("u", &us[cands[0].0]);
            let mut acc = first;
            for (i, _) in cands.iter().skip(1) {
                let v = body.bind("u", &us[*i]);
                acc = body.bind("u", &format!("select({acc}, {v}, {ci} == {i})"));
            }
            acc
        };
        let (v, g) = emit_form_eval(&mut body, sh, &form, &indices, &coeffs, &u, grad, d.facts.degree);
        values.push((r, v, g));
    }
    // Pick the chosen candidate's reference.
    let ref_of: Vec<usize> = plan.candidates.iter().map(|c| c.reference).collect();
    let pick = |body: &mut Body, which: &dyn Fn(&(usize, String, Option<String>)) -> String, prefix: &str| {
        let per_cand: Vec<String> =
            ref_of.iter().map(|r| which(values.iter().find(|(rr, _, _)| rr == r).unwrap())).collect();
        select_by_candidate(body, &ci, &per_cand, prefix)
    };
    let value = pick(&mut body, &|t| t.1.clone(), "val");
    if !grad {
        body.line(&format!("return {value};"));
        return body.text;
    }
    // grad_w = R^T grad_u per candidate, then grad_x = M grad_w.
    let per_cand: Vec<String> = plan
        .candidates
        .iter()
        .map(|c| {
            let g = values.iter().find(|(rr, _, _)| *rr == c.reference).unwrap().2.clone().unwrap();
            sh.perm_apply(&crate::symmetry::inverse(&c.rotation), &g)
        })
        .collect();
    let gw_terms: Vec<String> = per_cand.iter().map(|e| body.bind("gw", e)).collect();
    let gw = select_by_candidate(&mut body, &ci, &gw_terms, "gw");
    let gx: Vec<String> = (0..sh.s).map(|i| format!("{}({}) * {gw}.{}", sh.vecf, frame.cols[i], AXES[i])).collect();
    let gx = body.bind("gx", &gx.join(" + "));
    body.line(&format!("return vec{}<f32>({value}, {gx});", sh.s + 1));
    body.text
}

/// Naive frame: same folding, but sorting with `if` on mutable variables.
fn emit_frame_naive(body: &mut Body, sh: &Shapes, plan: &Plan, name: &str) -> Frame {
    match plan.locate {
        Locate::Fold { .. } => {
            // Declare mutable copies so the sorting can swap in place.
            let mut f = Body { text: String::new(), next: body.next, indent: body.indent };
            let fr = emit_frame(&mut f, sh, plan, name, true);
            body.next = f.next;
            // Turn the lets that the `if` swaps into vars.
            let mut text = f.text;
            for v in fr.cols.iter().chain(std::iter::once(&fr.w)) {
                text = text.replace(&format!("let {v} ="), &format!("var {v} ="));
            }
            body.text.push_str(&text);
            fr
        }
        Locate::Generic => {
            let mut f = Body { text: String::new(), next: body.next, indent: body.indent };
            let fr = emit_frame(&mut f, sh, plan, name, true);
            body.next = f.next;
            let mut text = f.text;
            if let Some(c) = &fr.class {
                text = text.replacen(&format!("let {c} ="), &format!("var {c} ="), 1);
            }
            text = text.replacen("let rep", "var rep", 1);
            body.text.push_str(&text);
            fr
        }
    }
}

/// Naive fetches: offsets from a lookup table, in a loop, into an array.
fn emit_fetches_naive(body: &mut Body, sh: &Shapes, plan: &Plan, frame: &Frame, ci: &str, name: &str) -> Vec<String> {
    let n = plan.fetches();
    body.line(&format!("var f: array<f32, {n}>;"));
    body.line(&format!("for (var k = 0; k < {n}; k++) {{"));
    body.line(&format!("    let q = {name}_OFFSETS[{ci} * {n} + k];"));
    let parts: Vec<String> = (0..sh.s).map(|i| format!("{} * q.{}", frame.cols[i], AXES[i])).collect();
    body.line(&format!("    f[k] = {name}_fetch({} + {});", frame.base, parts.join(" + ")));
    body.line("}");
    (0..n).map(|k| format!("f[{k}]")).collect()
}

/// Naive coefficients: a loop over a (coefficient, sample, weight) table.
fn emit_coefficients_naive(body: &mut Body, weights: &[Vec<Q>], samples: &[String], table: &str) -> Vec<String> {
    let n = weights.len();
    let arr = body.bind("bt", &format!("array<f32, {n}>()"));
    body.text = body.text.replace(&format!("let {arr} ="), &format!("var {arr} ="));
    let entries: usize = weights.iter().map(|w| w.iter().filter(|x| !x.is_zero()).count()).sum();
    body.line(&format!("for (var e = 0; e < {entries}; e++) {{"));
    body.line(&format!("    let t = {table}[e];"));
    body.line(&format!("    {arr}[i32(t.x)] += t.z * f[i32(t.y)];"));
    body.line("}");
    let _ = samples;
    (0..n).map(|i| format!("{arr}[{i}]")).collect()
}

/// Module-scope tables of the naive variant.
fn naive_tables(d: &Derivation, plan: &Plan, sh: &Shapes, name: &str) -> String {
    let mut out = String::new();
    let n = plan.fetches();
    let offs: Vec<String> = plan.candidates.iter().flat_map(|c| c.offsets.iter().map(|q| sh.ivec(q))).collect();
    let _ = writeln!(out, "const {name}_OFFSETS = array<{}, {}>({});", sh.veci, offs.len(), offs.join(", "));
    for r in plan.used_references() {
        let forms = d.forms(r);
        let form = match &forms.bb {
            Some(bb) => Form::Bb(bb),
            None => Form::Power(&forms.polys),
        };
        let (_, weights) = form_weights(&form);
        // slot of each stencil index
        let mut slot_of = vec![0usize; d.references[r].stencil.len()];
        for (slot, k) in plan.slots[r].iter().enumerate() {
            if let Some(k) = k {
                slot_of[*k] = slot;
            }
        }
        let mut entries = Vec::new();
        for (a, w) in weights.iter().enumerate() {
            for (k, x) in w.iter().enumerate() {
                if !x.is_zero() {
                    entries.push(format!("vec3<f32>({}.0, {}.0, {})", a, slot_of[k], lit(x)));
                }
            }
        }
        let _ = writeln!(out, "const {name}_W{r} = array<vec3<f32>, {}>({});", entries.len(), entries.join(", "));
    }
    let _ = n;
    out
}

/// Parity pivots of the cosets of 2Z^s in L: coordinates whose parity bits
/// number the cosets 0..2^k. Errors if 2Z^s is not a sublattice of L.
pub fn coset_pivots(lattice: &Lattice) -> Result<Vec<usize>> {
    let s = lattice.dim();
    for i in 0..s {
        let mut e = vec![0; s];
        e[i] = 2;
        if !lattice.contains(&e) {
            return Err(Error::Spec {
                origin: format!("lattice {}", lattice.name),
                message: "the packed layout needs 2Z^s inside the lattice; use --layout embedded".into(),
            });
        }
    }
    // Parity patterns in L form a GF(2) subspace; reduce to find pivots.
    let mut basis: Vec<u32> = Vec::new();
    for bits in 0u32..(1 << s) {
        let v: IVec = (0..s).map(|i| ((bits >> i) & 1) as i64).collect();
        if !lattice.contains(&v) {
            continue;
        }
        let mut x = bits;
        for b in &basis {
            if x & (1 << b.trailing_zeros()) != 0 {
                x ^= b;
            }
        }
        if x != 0 {
            // Keep the basis reduced on pivots.
            let p = x.trailing_zeros();
            for b in basis.iter_mut() {
                if *b & (1 << p) != 0 {
                    *b ^= x;
                }
            }
            basis.push(x);
        }
    }
    let mut pivots: Vec<usize> = basis.iter().map(|b| b.trailing_zeros() as usize).collect();
    pivots.sort();
    Ok(pivots)
}

/// Coset id of a lattice point from its parity (host-side mirror of the shader).
pub fn coset_of(pivots: &[usize], j: &[i64]) -> usize {
    pivots.iter().enumerate().map(|(i, &p)| ((j[p].rem_euclid(2)) as usize) << i).sum()
}

fn helpers(sh: &Shapes, plan: &Plan, name: &str) -> String {
    let mut out = String::new();
    let _ = writeln!(out, "/// floor(a / b) for b > 0, with integer arithmetic only.");
    let _ = writeln!(out, "fn {name}_floor_div(a: i32, b: i32) -> i32 {{");
    let _ = writeln!(out, "    return (a - ((a % b) + b) % b) / b;");
    let _ = writeln!(out, "}}\n");
    let _ = writeln!(out, "/// Is j a point of the lattice? (Hermite reduction to zero.)");
    let _ = writeln!(out, "fn {name}_is_lattice(j: {}) -> bool {{", sh.veci);
    let mut r = "j".to_string();
    for i in 0..sh.s {
        let h = plan.hermite[i][i];
        let _ = writeln!(
            out,
            "    let r{i} = {r} - {name}_floor_div({r}.{}, {h}) * {};",
            AXES[i],
            sh.ivec(&plan.hermite[i])
        );
        r = format!("r{i}");
    }
    let _ = writeln!(out, "    return all({r} == {}(0));", sh.veci);
    let _ = writeln!(out, "}}\n");
    out
}

/// Per-cube bounds function (min, max) from BB / tensor Bernstein coefficients.
fn cube_bounds_fn(d: &Derivation, sh: &Shapes, name: &str) -> String {
    let s = sh.s;
    let mut body = Body::new();
    // The cube [z, z+1]^s: fold about c = 2 round((z + 1/2) / 2) onto [0,1]^s
    // when folding applies; otherwise the cube's own class cells.
    let plan_nosort = crate::plan::Plan::without_sort(d);
    let zc = body.bind("zc", &format!("{}(z) + 0.5", sh.vecf));
    let frame_src = "p".to_string();
    body.line(&format!("let {frame_src} = {zc};"));
    let frame = emit_frame(&mut body, sh, &plan_nosort, name, false);
    // Union of all fetch offsets of all candidates.
    let mut union: Vec<IVec> = Vec::new();
    for c in &plan_nosort.candidates {
        for q in &c.offsets {
            if !union.contains(q) {
                union.push(q.clone());
            }
        }
    }
    let samples: Vec<String> = union
        .iter()
        .map(|q| {
            let pos = match frame_times(sh, &frame.cols, q) {
                Some(mq) => format!("{} + {mq}", frame.base),
                None => frame.base.clone(),
            };
            body.bind("f", &format!("{name}_fetch({pos})"))
        })
        .collect();
    let mut lo = "3.4e38".to_string();
    let mut hi = "-3.4e38".to_string();
    for c in &plan_nosort.candidates {
        let r = c.reference;
        let coef_weights = bound_weights(d, r);
        let mut per_k = vec![String::from("0.0"); d.references[r].stencil.len()];
        for (slot, k) in plan_nosort.slots[r].iter().enumerate() {
            if let Some(k) = k {
                let q = &c.offsets[slot];
                per_k[*k] = samples[union.iter().position(|x| x == q).unwrap()].clone();
            }
        }
        let coeffs = emit_coefficients(&mut body, &coef_weights, &per_k, "b");
        let mn = coeffs.iter().skip(1).fold(coeffs[0].clone(), |a, b| format!("min({a}, {b})"));
        let mx = coeffs.iter().skip(1).fold(coeffs[0].clone(), |a, b| format!("max({a}, {b})"));
        let (mn, mx) = match &frame.class {
            Some(cls) => (
                format!("select(3.4e38, {mn}, {cls} == {})", c.class),
                format!("select(-3.4e38, {mx}, {cls} == {})", c.class),
            ),
            None => (mn, mx),
        };
        lo = body.bind("lo", &format!("min({lo}, {mn})"));
        hi = body.bind("hi", &format!("max({hi}, {mx})"));
    }
    body.line(&format!("return vec2<f32>({lo}, {hi});"));
    let _ = s;
    format!(
        "/// Bounds (min, max) of the spline over the unit cube [z, z+1]: the BB (or\n/// tensor Bernstein) coefficients of every piece meeting it bound it.\nfn {name}_cube_bounds(z: {}) -> vec2<f32> {{\n{}}}\n",
        sh.veci, body.text
    )
}

/// Bounding coefficients of reference r as weights of its stencil: BB
/// coefficients for simplices, tensor Bernstein coefficients over the cell's
/// bounding box otherwise.
fn bound_weights(d: &Derivation, r: usize) -> Vec<Vec<Q>> {
    let forms = d.forms(r);
    if let Some(bb) = &forms.bb {
        return bb.weights.clone();
    }
    let s = d.facts.dim;
    let origin = d.cube_origin(&d.references[r].corner);
    let local: Vec<QVec> = d.references[r].vertices.iter().map(|v| sub_q(v, &origin)).collect();
    let lo: QVec = (0..s).map(|i| local.iter().map(|v| v[i].clone()).min().unwrap()).collect();
    let hi: QVec = (0..s).map(|i| local.iter().map(|v| v[i].clone()).max().unwrap()).collect();
    // u = lo + (hi - lo) t
    let a: Vec<QVec> =
        (0..s).map(|i| (0..s).map(|j| if i == j { &hi[i] - &lo[i] } else { Q::zero() }).collect()).collect();
    let polys: Vec<Poly> = forms.polys.iter().map(|p| p.compose_affine(&a, &lo)).collect();
    let n: Vec<u32> = (0..s)
        .map(|i| {
            polys
                .iter()
                .flat_map(|p| p.basis.exps.iter().zip(&p.coeffs))
                .filter(|(_, c)| !c.is_zero())
                .map(|(e, _)| e[i])
                .max()
                .unwrap_or(0)
        })
        .collect();
    // Tensor Bernstein multi-indices I <= n.
    let mut idx: Vec<Vec<u32>> = vec![vec![]];
    for i in 0..s {
        idx = idx
            .into_iter()
            .flat_map(|p| {
                (0..=n[i]).map(move |k| {
                    let mut q = p.clone();
                    q.push(k);
                    q
                })
            })
            .collect();
    }
    idx.iter()
        .map(|big_i| {
            polys
                .iter()
                .map(|p| {
                    let mut acc = Q::zero();
                    for (e, c) in p.basis.exps.iter().zip(&p.coeffs) {
                        if c.is_zero() || (0..s).any(|i| e[i] > big_i[i]) {
                            continue;
                        }
                        let mut f = c.clone();
                        for i in 0..s {
                            f = f * binomial(big_i[i], e[i]) / binomial(n[i], e[i]);
                        }
                        acc += &f;
                    }
                    acc
                })
                .collect()
        })
        .collect()
}

/// Counts operators, selects, comparisons and builtin calls in WGSL source.
pub fn count_ops(src: &str) -> usize {
    let mut n = 0;
    for tok in [
        " + ", " - ", " * ", " / ", "select(", " < ", " <= ", " >= ", " == ", "abs(", "round(", "floor(", "min(",
        "max(", " & ",
    ] {
        n += src.matches(tok).count();
    }
    n
}

/// Emits the module for one filter.
pub fn emit(d: &Derivation, opts: &EmitOptions) -> Result<Emitted> {
    let plan = Plan::new(d);
    let s = d.facts.dim;
    let sh = Shapes::new(s);
    let name = &d.filter.name;
    let naive = opts.variant == Variant::Naive;
    let eval_body = emit_eval_body(d, &plan, &sh, name, false, naive);
    let grad_body = emit_eval_body(d, &plan, &sh, name, true, naive);
    let mut helper_text = helpers(&sh, &plan, name);
    if naive {
        helper_text.push_str(&naive_tables(d, &plan, &sh, name));
        helper_text.push('\n');
    }
    if opts.kernels {
        helper_text.push_str(&cube_bounds_fn(d, &sh, name));
    }
    let swz: String = AXES[..s].concat();
    let (coset_expr, linear_expr, cosets, coset_formula) =
        match opts.layout {
            Layout::Packed => {
                let piv = coset_pivots(&d.filter.lattice)?;
                let expr: Vec<String> =
                    piv.iter()
                        .enumerate()
                        .map(|(i, &p)| {
                            if i == 0 {
                                format!("(j.{} & 1)", AXES[p])
                            } else {
                                format!("((j.{} & 1) << {i}u)", AXES[p])
                            }
                        })
                        .collect();
                let expr = if expr.is_empty() { "0".to_string() } else { expr.join(" + ") };
                let lin = if s == 3 {
                    format!("(m.z * {name}_grid.size.y + m.y) * {name}_grid.size.x + m.x")
                } else {
                    format!("m.y * {name}_grid.size.x + m.x")
                };
                let formula = expr.clone();
                (expr, lin, 1usize << piv.len(), formula)
            }
            Layout::Embedded => (String::new(), String::new(), 0, String::new()),
        };
    let extent_product = if s == 3 { "e.x * e.y * e.z" } else { "e.x * e.y" };
    let delinearize =
        if s == 3 { "vec3<i32>(i % e.x, (i / e.x) % e.y, i / (e.x * e.y))" } else { "vec2<i32>(i % e.x, i / e.x)" };
    let (block_volume, cube_in_block) = if s == 3 {
        ("b * b * b", "vec3<i32>(t % b, (t / b) % b, t / (b * b))")
    } else {
        ("b * b", "vec2<i32>(t % b, t / b)")
    };
    let mut prefilter_body = String::new();
    for (k, w) in &d.prefilter.taps {
        let neg: IVec = k.iter().map(|x| -x).collect();
        let _ = writeln!(prefilter_body, "    acc += {} * {name}_fetch(j + {});", lit(w), sh.ivec(&neg));
    }
    let out_binding = opts.binding + if opts.layout == Layout::Packed { 2 } else { 1 };
    let env = template_env();
    let tmpl = env.get_template("module.wgsl.j2").expect("module template");
    let ctx = minijinja::context! {
        command => opts.command.clone(),
        name => name,
        lattice => d.filter.lattice.name.clone(),
        dim => s,
        layout => opts.layout.name(),
        variant => opts.variant.name(),
        locate => match plan.locate { Locate::Fold { sort: true } => "fold + sorting network + plane tests", Locate::Fold { sort: false } => "fold + plane tests", Locate::Generic => "generic select over cube classes and cells" },
        fetches => plan.fetches(),
        vector_adds => plan.vector_adds,
        matvec_adds => plan.matvec_adds,
        group => opts.group,
        binding => opts.binding,
        out_binding => out_binding,
        vecf => sh.vecf,
        veci => sh.veci,
        vecu => format!("vec{s}<u32>"),
        gradf => format!("vec{}<f32>", s + 1),
        swz => swz,
        coset_expr => coset_expr,
        coset_formula => coset_formula,
        cosets => cosets,
        linear_expr => linear_expr,
        helpers => helper_text,
        eval_body => eval_body.clone(),
        grad_body => grad_body.clone(),
        has_kernels => opts.kernels,
        extent_product => extent_product,
        delinearize => delinearize,
        block_volume => block_volume,
        cube_in_block => cube_in_block,
        prefilter_body => prefilter_body,
    };
    let source = tmpl.render(ctx).map_err(|e| Error::Spec { origin: "templates".into(), message: e.to_string() })?;
    let stats = EmitStats {
        layout: opts.layout,
        variant: opts.variant,
        locate: format!("{:?}", plan.locate),
        candidates: plan.candidates.len(),
        fetches_per_eval: plan.fetches(),
        vector_adds: plan.vector_adds,
        matvec_adds: plan.matvec_adds,
        ops_eval: count_ops(&eval_body),
        ops_eval_grad: count_ops(&grad_body),
    };
    Ok(Emitted { file_name: file_name(name, opts.layout, opts.variant), source, stats })
}

/// The templates, embedded at build time so the generator works as a
/// build-dependency without the repository around it.
fn template_env() -> minijinja::Environment<'static> {
    let mut env = minijinja::Environment::new();
    env.set_syntax(
        minijinja::syntax::SyntaxConfig::builder()
            .keep_trailing_newline(true)
            .trim_blocks(true)
            .build()
            .expect("syntax config"),
    );
    for (n, src) in [
        ("module.wgsl.j2", include_str!("../../templates/module.wgsl.j2")),
        ("fetch_embedded.wgsl.j2", include_str!("../../templates/fetch_embedded.wgsl.j2")),
        ("fetch_packed.wgsl.j2", include_str!("../../templates/fetch_packed.wgsl.j2")),
        ("kernels.wgsl.j2", include_str!("../../templates/kernels.wgsl.j2")),
    ] {
        env.add_template(n, src).expect("template parses");
    }
    env
}
