//! Stencils (docs/BOX_SPLINES.md §3.6): the lattice points whose shifted support
//! meets a cell, found by the zonotope's knot-plane half-widths.

use crate::derive::spline::SplineFacts;
use crate::math::exact::Q;
use crate::math::linalg::{dot_iq, IVec, QVec};
use crate::spec::lattice::Lattice;

/// Lattice points j with x - j strictly inside the support of phi (x must be
/// off the knot planes, e.g. a cell's interior point). The zonotope test runs
/// in f64 and falls back to exact arithmetic near its boundary.
///
/// # Panics
///
/// If `x` ± the support half-widths leaves the i64 range.
pub fn stencil_points(facts: &SplineFacts, lattice: &Lattice, x: &[Q]) -> Vec<IVec> {
    const IN_RANGE: &str =
        "x ± the support half-widths is within the i64 range (the precondition; callers pass cell interiors)";
    let s = facts.dim;
    let half: Vec<Q> = (0..s).map(|i| Q::frac(facts.directions.iter().map(|d| d[i].abs()).sum(), 2)).collect();
    let lo: IVec = (0..s).map(|i| (&x[i] - &half[i]).floor_i64().expect(IN_RANGE)).collect();
    let hi: IVec = (0..s).map(|i| (&x[i] + &half[i]).floor_i64().expect(IN_RANGE) + 1).collect();
    let planes: Vec<(&IVec, f64, f64)> =
        facts.normals.iter().map(|n| (n, dot_iq(n, x).to_f64(), facts.support_half_width(n).to_f64())).collect();
    let mut out = Vec::new();
    let mut j = lo.clone();
    loop {
        let mut inside = true;
        let mut unsure = false;
        for (n, nx, h) in &planes {
            let m = h - (nx - crate::math::linalg::dot_i(n, &j) as f64).abs();
            if m < -1e-9 {
                inside = false;
                break;
            }
            if m <= 1e-9 {
                unsure = true;
            }
        }
        if inside && unsure {
            let y: QVec = x.iter().zip(&j).map(|(a, b)| a - &Q::int(*b)).collect();
            inside = facts.in_open_support(&y);
        }
        if inside && lattice.contains(&j) {
            out.push(j.clone());
        }
        let mut k = 0;
        loop {
            if k == s {
                return out;
            }
            j[k] += 1;
            if j[k] <= hi[k] {
                break;
            }
            j[k] = lo[k];
            k += 1;
        }
    }
}
