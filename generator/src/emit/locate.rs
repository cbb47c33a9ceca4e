//! Branch-free point location in WGSL: the frame (fold, sorting network or
//! generic class select), the candidate choice by plane tests, and the
//! axis-aligned fetch walk.

/// How the polynomial of each reference piece is written (the plan-based forms).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PieceForm {
    /// BB coefficients (power form on non-simplices) as dense combinations
    /// of every sample, de Casteljau: the first milestone's form.
    Dense,
    /// Power form: monomial coefficients with shared subexpressions, Horner.
    Power,
    /// BB coefficients with shared subexpressions, de Casteljau (power form
    /// with Horner on non-simplicial pieces).
    Bb,
    /// Linear-form (ridge) form: sums of products of powers of knot-plane
    /// linear forms, weights with shared subexpressions.
    Ridge,
}

use super::{forms::*, writer::*};
use crate::derive::Derivation;
use crate::emit::plan::{Candidate, Locate, Plan};
use crate::math::exact::Q;
use crate::math::linalg::{IVec, QVec};

/// The frame: base (veci), columns of M (veci names), w (vecf), class (i32 or None).
pub(crate) struct Frame {
    pub(crate) base: String,
    pub(crate) cols: Vec<String>,
    pub(crate) w: String,
    pub(crate) class: Option<String>,
}

/// How an eval body is written, step by step: the seam between the fast
/// (branch-free) code of this module and the naive variant (`if`, loops and
/// lookup tables, in `naive.rs`), which shares the mathematics and differs
/// only in these steps. It is a trait rather than a flag so that the naive
/// code lives in its own module and this one does not depend on it.
pub(crate) trait BodyStyle {
    /// The piece form actually written when `requested` is asked for.
    fn piece_form(&self, requested: PieceForm) -> PieceForm;
    /// One compare-exchange of the sorting network on `w` and the frame columns.
    fn sort_step(&self, body: &mut Body, w: &mut String, cols: &mut [String], i: usize, j: usize);
    /// Class `k` (with representative `rep_k`) replaces `cls`/`rep` where `hit` holds.
    fn class_step(&self, body: &mut Body, cls: &mut String, rep: &mut String, hit: &str, k: usize, rep_k: &str);
    /// The frame (see [`emit_frame`] for the shared part).
    fn frame(&self, body: &mut Body, sh: &Shapes, plan: &Plan, name: &str) -> Frame;
    /// The candidate index among several (i32 expression); `tests[i]` are
    /// the conditions of candidate i, as `&`-joined boolean terms.
    fn candidate_choice(&self, body: &mut Body, tests: &[String]) -> String;
    /// The fetches of every slot: the sample names per slot.
    fn fetches(&self, body: &mut Body, sh: &Shapes, plan: &Plan, frame: &Frame, ci: &str, name: &str) -> Vec<String>;
    /// The coefficients (one expression per row of `weights`) of reference
    /// piece `r` from the samples per stencil index.
    fn coefficients(
        &self,
        body: &mut Body,
        weights: &[Vec<Q>],
        samples: &[String],
        piece: PieceForm,
        name: &str,
        r: usize,
    ) -> Vec<String>;
}

/// The fast variant: branch-free selects, unrolled fetches and coefficients.
pub(crate) struct Fast;

impl BodyStyle for Fast {
    fn piece_form(&self, requested: PieceForm) -> PieceForm {
        requested
    }

    fn sort_step(&self, body: &mut Body, w: &mut String, cols: &mut [String], i: usize, j: usize) {
        let swz = swizzle_swapped(cols.len(), i, j);
        let sw = body.bind("sw", &format!("{w}.{} < {w}.{}", AXES[i], AXES[j]));
        let nw = body.bind("w", &format!("select({w}, {w}.{swz}, {sw})"));
        let ci = body.bind("m", &format!("select({}, {}, {sw})", cols[i], cols[j]));
        let cj = body.bind("m", &format!("select({}, {}, {sw})", cols[j], cols[i]));
        *w = nw;
        cols[i] = ci;
        cols[j] = cj;
    }

    fn class_step(&self, body: &mut Body, cls: &mut String, rep: &mut String, hit: &str, k: usize, rep_k: &str) {
        *cls = body.bind("cls", &format!("select({cls}, {k}, {hit})"));
        *rep = body.bind("rep", &format!("select({rep}, {rep_k}, {hit})"));
    }

    fn frame(&self, body: &mut Body, sh: &Shapes, plan: &Plan, name: &str) -> Frame {
        emit_frame(body, sh, plan, name, self)
    }

    fn candidate_choice(&self, body: &mut Body, tests: &[String]) -> String {
        let mut ci = "0".to_string();
        for (i, t) in tests.iter().enumerate().skip(1) {
            let inside = body.bind("in", t);
            ci = body.bind("ci", &format!("select({ci}, {i}, {inside})"));
        }
        ci
    }

    fn fetches(&self, body: &mut Body, sh: &Shapes, plan: &Plan, frame: &Frame, ci: &str, name: &str) -> Vec<String> {
        emit_fetches(body, sh, plan, frame, ci, name)
    }

    fn coefficients(
        &self,
        body: &mut Body,
        weights: &[Vec<Q>],
        samples: &[String],
        piece: PieceForm,
        _name: &str,
        _r: usize,
    ) -> Vec<String> {
        if piece == PieceForm::Dense {
            emit_coefficients(body, weights, samples, "b")
        } else {
            crate::emit::cse::LinearMap::shared(weights).emit(body, samples, "b")
        }
    }
}

/// The swizzle of `s` axes with axes `i` and `j` exchanged (e.g. `yxz`).
pub(crate) fn swizzle_swapped(s: usize, i: usize, j: usize) -> String {
    let mut swz: Vec<&str> = AXES[..s].to_vec();
    swz.swap(i, j);
    swz.concat()
}

/// The frame, with the sorting network's compare-exchanges and the class
/// selection written by `style`.
pub(crate) fn emit_frame(body: &mut Body, sh: &Shapes, plan: &Plan, name: &str, style: &dyn BodyStyle) -> Frame {
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
                    style.sort_step(body, &mut w, &mut cols, i, j);
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
                style.class_step(body, &mut cls, &mut rep, &hit, k, &sh.ivec(&plan.classes[k]));
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

/// Index of the chosen candidate (an i32 expression; "0" when only one),
/// written by `style`.
pub(crate) fn emit_candidate_choice(
    body: &mut Body,
    sh: &Shapes,
    plan: &Plan,
    frame: &Frame,
    style: &dyn BodyStyle,
) -> String {
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
    let tests: Vec<String> = plan.candidates.iter().map(tests).collect();
    style.candidate_choice(body, &tests)
}

/// select chain over candidates: values[i] when ci == i.
pub(crate) fn select_by_candidate(body: &mut Body, ci: &str, values: &[String], prefix: &str) -> String {
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
pub(crate) fn frame_times(sh: &Shapes, cols: &[String], q: &[i64]) -> Option<String> {
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
pub(crate) fn emit_fetches(
    body: &mut Body,
    sh: &Shapes,
    plan: &Plan,
    frame: &Frame,
    ci: &str,
    name: &str,
) -> Vec<String> {
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
pub(crate) fn local_coords(sh: &Shapes, d: &Derivation, plan: &Plan, c: &Candidate, w: &str) -> String {
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

/// One reference piece's emitted value: (reference, value expression,
/// gradient expression, Hessian entries row-major when asked).
type PieceValue = (usize, String, Option<String>, Vec<String>);

/// The body of eval (order 0), eval_grad (order 1) or eval_hessian (order 2,
/// returning `<name>_Hessian`). The ridge form has no second-order code: with
/// order 2 it is written as the power form.
pub(crate) fn emit_eval_body(
    d: &Derivation,
    plan: &Plan,
    sh: &Shapes,
    name: &str,
    order: usize,
    style: &dyn BodyStyle,
    piece: PieceForm,
) -> String {
    let grad = order >= 1;
    let mut piece = style.piece_form(piece);
    if order >= 2 && piece == PieceForm::Ridge {
        piece = PieceForm::Power;
    }
    let mut body = Body::new();
    let frame = style.frame(&mut body, sh, plan, name);
    let ci = emit_candidate_choice(&mut body, sh, plan, &frame, style);
    let samples_by_slot = style.fetches(&mut body, sh, plan, &frame, &ci, name);
    let mut values: Vec<PieceValue> = Vec::new();
    for r in plan.used_references() {
        let forms = d.forms(r);
        let form = match (&forms.bb, piece) {
            (Some(bb), PieceForm::Dense | PieceForm::Bb) => Form::Bb(bb),
            _ => Form::Power(&forms.polys),
        };
        let ridge = (piece == PieceForm::Ridge).then(|| d.ridge(r));
        // The ridge form writes its sample combinations with its evaluation (below).
        let (indices, weights) = match ridge {
            Some(_) => (vec![], vec![]),
            None => form_weights(&form),
        };
        // samples per stencil index, via the slot mapping.
        let nst = d.references[r].stencil.len();
        let mut per_k = vec![String::from("0.0"); nst];
        for (slot, k) in plan.slots[r].iter().enumerate() {
            if let Some(k) = k {
                per_k[*k] = samples_by_slot[slot].clone();
            }
        }
        let coeffs = style.coefficients(&mut body, &weights, &per_k, piece, name, r);
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
        let (v, g, h) = match (&form, piece) {
            _ if ridge.is_some() => {
                let rf = ridge.expect("checked by the guard");
                let vars: Vec<String> = (0..sh.s).map(|i| format!("{u}.{}", AXES[i])).collect();
                // The plain grouping and the merged one (H * affine multipliers):
                // keep the piece's cheaper code.
                let mut best: Option<(usize, Body, String, Option<String>)> = None;
                for form in [rf.clone(), rf.merged()] {
                    let mut b = Body { text: String::new(), next: body.next, indent: body.indent };
                    let coeffs = crate::emit::cse::LinearMap::shared(&form.rows()).emit(&mut b, &per_k, "b");
                    let (v, g) = crate::emit::ridge::emit_ridge(&mut b, &form, &coeffs, &vars, grad);
                    let v = b.bind("v", &v);
                    let g = grad.then(|| b.bind("g", &sh.fvec(&g)));
                    let ops = count_ops(&b.text);
                    if best.as_ref().is_none_or(|(o, ..)| ops < *o) {
                        best = Some((ops, b, v, g));
                    }
                }
                let (_, b, v, g) = best.expect("two candidates were emitted");
                body.text.push_str(&b.text);
                body.next = b.next;
                (v, g, vec![])
            }
            (Form::Power(_), PieceForm::Power | PieceForm::Bb | PieceForm::Ridge) => {
                let vars: Vec<String> = (0..sh.s).map(|i| format!("{u}.{}", AXES[i])).collect();
                let monomials: Vec<(Vec<u32>, String)> = indices.iter().cloned().zip(coeffs.iter().cloned()).collect();
                let (v, g, h) = crate::emit::horner::emit_horner(&mut body, &monomials, &vars, order);
                let v = body.bind("v", &v);
                (v, grad.then(|| body.bind("g", &sh.fvec(&g))), h)
            }
            _ => emit_form_eval(&mut body, sh, &form, &indices, &coeffs, &u, order, d.facts.degree),
        };
        values.push((r, v, g, h));
    }
    // Pick the chosen candidate's reference.
    const USED: &str = "values holds every used reference, and used_references are the candidates' references";
    let ref_of: Vec<usize> = plan.candidates.iter().map(|c| c.reference).collect();
    let pick = |body: &mut Body, which: &dyn Fn(&PieceValue) -> String, prefix: &str| {
        let per_cand: Vec<String> =
            ref_of.iter().map(|r| which(values.iter().find(|(rr, ..)| rr == r).expect(USED))).collect();
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
            let g = values
                .iter()
                .find(|(rr, ..)| *rr == c.reference)
                .expect(USED)
                .2
                .clone()
                .expect("with grad, every piece value carries its gradient");
            sh.perm_apply(&crate::derive::symmetry::inverse(&c.rotation), &g)
        })
        .collect();
    let gw_terms: Vec<String> = per_cand.iter().map(|e| body.bind("gw", e)).collect();
    let gw = select_by_candidate(&mut body, &ci, &gw_terms, "gw");
    let gx: Vec<String> = (0..sh.s).map(|i| format!("{}({}) * {gw}.{}", sh.vecf, frame.cols[i], AXES[i])).collect();
    let gx = body.bind("gx", &gx.join(" + "));
    if order < 2 {
        body.line(&format!("return {};", sh.grad_result(name, &value, &gx)));
        return body.text;
    }
    // Hessian: H_w = R^T H_u R per candidate (column j of H_w is column k of
    // H_u, where R[k][j] = +-1, permuted by R^T and signed), then H_x = M H_w M^T.
    let s = sh.s;
    let hu_cols: Vec<(usize, Vec<String>)> = values
        .iter()
        .map(|(r, _, _, h)| {
            let cols = (0..s)
                .map(|k| {
                    let comps: Vec<String> = (0..s).map(|i| h[i * s + k].clone()).collect();
                    if comps.iter().all(|c| c == "0.0") {
                        format!("{}(0.0)", sh.vecf)
                    } else {
                        body.bind("hc", &sh.fvec(&comps))
                    }
                })
                .collect();
            (*r, cols)
        })
        .collect();
    let hw_cols: Vec<String> = (0..s)
        .map(|j| {
            let per_cand: Vec<String> = plan
                .candidates
                .iter()
                .map(|c| {
                    let cols = &hu_cols.iter().find(|(rr, _)| *rr == c.reference).expect(USED).1;
                    let (k, sgn) = (0..s)
                        .find_map(|k| (c.rotation[k][j] != 0).then_some((k, c.rotation[k][j])))
                        .expect("every column of a signed permutation has one non-zero entry");
                    let col = sh.perm_apply(&crate::derive::symmetry::inverse(&c.rotation), &cols[k]);
                    let e = if sgn > 0 { col } else { format!("-{col}") };
                    body.bind("hw", &e)
                })
                .collect();
            select_by_candidate(&mut body, &ci, &per_cand, "hw")
        })
        .collect();
    let mat = format!("mat{s}x{s}<f32>");
    let hw = body.bind("hm", &format!("{mat}({})", hw_cols.join(", ")));
    let m_cols: Vec<String> = frame.cols.iter().map(|c| format!("{}({c})", sh.vecf)).collect();
    let mf = body.bind("mf", &format!("{mat}({})", m_cols.join(", ")));
    let hx = body.bind("hx", &format!("{mf} * {hw} * transpose({mf})"));
    body.line(&format!("return {name}_Hessian({value}, {gx}, {hx});"));
    body.text
}
