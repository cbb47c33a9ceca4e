//! Per-cube bounds for empty-space skipping: BB (or tensor Bernstein)
//! coefficients bound the spline on each piece.

use super::{forms::*, locate::*, writer::*};
use crate::derive::Derivation;
use crate::math::exact::{binomial, Q};
use crate::math::linalg::{sub_q, IVec, QVec};
use crate::math::poly::Poly;

/// Per-cube bounds function (min, max) from BB / tensor Bernstein coefficients.
pub(crate) fn cube_bounds_fn(d: &Derivation, sh: &Shapes, name: &str) -> String {
    let s = sh.s;
    let mut body = Body::new();
    // The cube [z, z+1]^s: fold about c = 2 round((z + 1/2) / 2) onto [0,1]^s
    // when folding applies; otherwise the cube's own class cells.
    let plan_nosort = crate::emit::plan::Plan::without_sort(d);
    let zc = body.bind("zc", &format!("{}(z) + 0.5", sh.vecf));
    let frame_src = "p".to_string();
    body.line(&format!("let {frame_src} = {zc};"));
    let frame = emit_frame(&mut body, sh, &plan_nosort, name, &Fast);
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
                per_k[*k] = samples
                    [union.iter().position(|x| x == q).expect("the union holds every candidate's offsets")]
                .clone();
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
pub(crate) fn bound_weights(d: &Derivation, r: usize) -> Vec<Vec<Q>> {
    let forms = d.forms(r);
    if let Some(bb) = &forms.bb {
        return bb.weights.clone();
    }
    let s = d.facts.dim;
    let origin = d.cube_origin(&d.references[r].corner);
    let local: Vec<QVec> = d.references[r].vertices.iter().map(|v| sub_q(v, &origin)).collect();
    const VERTICES: &str = "a full-dimensional cell has at least s + 1 vertices";
    let lo: QVec = (0..s).map(|i| local.iter().map(|v| v[i].clone()).min().expect(VERTICES)).collect();
    let hi: QVec = (0..s).map(|i| local.iter().map(|v| v[i].clone()).max().expect(VERTICES)).collect();
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
