//! The naive variant: the same mathematics with `if`, loops and lookup
//! tables, so the benefit of the fast variant can be measured.

use super::{forms::*, locate::*, writer::*};
use crate::derive::Derivation;
use crate::emit::plan::{Locate, Plan};
use crate::math::exact::Q;
use std::fmt::Write;

/// The naive variant's [`BodyStyle`]: `if` on mutable variables, fetches in
/// a loop over an offset table, coefficients in a loop over a weight table.
/// It always writes the dense form: it measures branches and lookup tables,
/// not the choice of form.
pub(crate) struct Naive;

impl BodyStyle for Naive {
    fn piece_form(&self, _requested: PieceForm) -> PieceForm {
        PieceForm::Dense
    }

    fn sort_step(&self, body: &mut Body, w: &mut String, cols: &mut [String], i: usize, j: usize) {
        let swz = swizzle_swapped(cols.len(), i, j);
        body.line(&format!("if ({w}.{} < {w}.{}) {{", AXES[i], AXES[j]));
        body.line(&format!("    {w} = {w}.{swz};"));
        body.line(&format!("    let t = {};", cols[i]));
        body.line(&format!("    {} = {};", cols[i], cols[j]));
        body.line(&format!("    {} = t;", cols[j]));
        body.line("}");
    }

    fn class_step(&self, body: &mut Body, cls: &mut String, rep: &mut String, hit: &str, k: usize, rep_k: &str) {
        body.line(&format!("if ({hit}) {{ {cls} = {k}; {rep} = {rep_k}; }}"));
    }

    fn frame(&self, body: &mut Body, sh: &Shapes, plan: &Plan, name: &str) -> Frame {
        emit_frame_naive(body, sh, plan, name)
    }

    fn candidate_choice(&self, body: &mut Body, tests: &[String]) -> String {
        body.line("var ci = 0;");
        for (i, t) in tests.iter().enumerate().skip(1) {
            body.line(&format!("if ({}) {{ ci = {i}; }}", t.replace(" & ", " && ")));
        }
        "ci".into()
    }

    fn fetches(&self, body: &mut Body, sh: &Shapes, plan: &Plan, frame: &Frame, ci: &str, name: &str) -> Vec<String> {
        emit_fetches_naive(body, sh, plan, frame, ci, name)
    }

    fn coefficients(
        &self,
        body: &mut Body,
        weights: &[Vec<Q>],
        samples: &[String],
        _piece: PieceForm,
        name: &str,
        r: usize,
    ) -> Vec<String> {
        emit_coefficients_naive(body, weights, samples, &format!("{name}_W{r}"))
    }
}

/// Naive frame: same folding, but sorting with `if` on mutable variables.
pub(crate) fn emit_frame_naive(body: &mut Body, sh: &Shapes, plan: &Plan, name: &str) -> Frame {
    match plan.locate {
        Locate::Fold { .. } => {
            // Declare mutable copies so the sorting can swap in place.
            let mut f = Body { text: String::new(), next: body.next, indent: body.indent };
            let fr = emit_frame(&mut f, sh, plan, name, &Naive);
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
            let fr = emit_frame(&mut f, sh, plan, name, &Naive);
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
pub(crate) fn emit_fetches_naive(
    body: &mut Body,
    sh: &Shapes,
    plan: &Plan,
    frame: &Frame,
    ci: &str,
    name: &str,
) -> Vec<String> {
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
pub(crate) fn emit_coefficients_naive(
    body: &mut Body,
    weights: &[Vec<Q>],
    samples: &[String],
    table: &str,
) -> Vec<String> {
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
pub(crate) fn naive_tables(d: &Derivation, plan: &Plan, sh: &Shapes, name: &str) -> String {
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
