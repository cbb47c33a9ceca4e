//! The exact side of the device checks: the f64 evaluator on every core,
//! the tolerances a device value and gradient are held to, the band around
//! each knot plane where f32 may place a point in the neighbouring piece,
//! and the running tally of the comparison.

use crate::par::par_map;
use crate::volume::LatticeVolume;
use boxforge::derive::Derivation;

/// Exact (f64) evaluation at the points, on all cores.
pub fn cpu_eval(d: &Derivation, vol: &LatticeVolume, points: &[[f32; 4]]) -> Vec<(f64, Vec<f64>)> {
    let data = |j: &[i64]| vol.get(j) as f64;
    let _ = d.f64_tables();
    par_map(points, |p| d.eval_f64(&[p[0] as f64, p[1] as f64, p[2] as f64], &data))
}

/// Value tolerance: |GPU value - exact value| <= this times the data range.
pub const VALUE_TOLERANCE: f64 = 1e-5;
/// Gradient tolerance: |grad_gpu - grad_exact|_inf / max(|grad_exact|_inf, range) <= this.
pub const GRADIENT_TOLERANCE: f64 = 1e-4;

/// How far (in units of n . x) a point may be from the knot plane
/// n . x = c and still be placed by the device in the piece on either side:
/// `4 f32::EPSILON (|n|_1 |x|_max + |c|)`.
///
/// The points are f32 and the exact evaluator takes them exactly, but the
/// device locates them with f32 arithmetic: the shift to the cube (x - z,
/// exact), the map to the reference piece and the plane tests n . u <= b,
/// each a short sum of integer multiples of coordinates. |n|_1 |x|_max bounds
/// every partial sum of n . x (and of the local coordinates' forms) and |c|
/// the constant it is compared with; each of the at most s + 1 = 4 rounded
/// additions errs by at most eps/2 of that, so 4 eps is about twice the
/// worst case for 3D, and still a band of ~1e-5 around each plane (a small
/// fraction of the points, counted in the report).
pub fn knot_tolerance(normal: &[i64], c: f64, x_max: f64) -> f64 {
    let n1: f64 = normal.iter().map(|a| a.unsigned_abs() as f64).sum();
    4.0 * f32::EPSILON as f64 * (n1 * x_max + c.abs())
}

/// The knot plane n . x = c nearest to x of every family the derivation's
/// arrangement has, with |n . x - c| and [`knot_tolerance`] for it.
pub fn nearest_knot_planes(d: &Derivation, x: &[f64]) -> Vec<(Vec<i64>, f64, f64, f64)> {
    let x_max = x.iter().fold(0f64, |m, a| m.max(a.abs()));
    d.arrangement
        .families
        .iter()
        .map(|f| {
            let (offset, period) = (f.offset.to_f64(), f.period as f64);
            let v: f64 = f.normal.iter().zip(x).map(|(n, a)| *n as f64 * a).sum();
            let c = offset + ((v - offset) / period).round() * period;
            (f.normal.clone(), c, (v - c).abs(), knot_tolerance(&f.normal, c, x_max))
        })
        .collect()
}

/// Is x within [`knot_tolerance`] of a knot plane? Returns the largest
/// such tolerance in x units (|n . x - c| / |n|_1 <= tol / |n|_1), or None.
pub fn near_knot(d: &Derivation, x: &[f64]) -> Option<f64> {
    nearest_knot_planes(d, x)
        .into_iter()
        .filter(|(_, _, dist, tol)| dist <= tol)
        .map(|(n, _, _, tol)| tol / n.iter().map(|a| a.unsigned_abs() as f64).sum::<f64>())
        .reduce(f64::max)
}

/// The running comparison of device values against the exact evaluator.
#[derive(Clone, Debug, Default)]
pub struct Tally {
    pub data_range: f64,
    pub max_abs: f64,
    pub max_rel: f64,
    pub points: usize,
    pub near_knot_points: usize,
    pub accepted_other_side: usize,
}

impl Tally {
    pub fn new(data_range: f64) -> Tally {
        Tally { data_range, ..Tally::default() }
    }

    /// (value error, relative gradient error) of one device result against
    /// an exact value and gradient.
    pub(crate) fn errors(&self, v: f32, g: &[f32; 4], ev: f64, eg: &[f64]) -> (f64, f64) {
        let abs = (v as f64 - ev).abs().max((g[0] as f64 - ev).abs());
        let gmax = eg.iter().fold(0f64, |m, x| m.max(x.abs()));
        let diff = (0..3).fold(0f64, |m, i| m.max((g[i + 1] as f64 - eg[i]).abs()));
        (abs, diff / gmax.max(self.data_range))
    }

    pub(crate) fn within(&self, (abs, rel): (f64, f64)) -> bool {
        abs <= VALUE_TOLERANCE * self.data_range && rel <= GRADIENT_TOLERANCE
    }

    /// Compares device values and gradients at `pts` with the exact
    /// evaluator. A point within [`knot_tolerance`] of a knot plane passes
    /// when it matches the piece on any side of the planes it is near
    /// ([`Derivation::eval_f64_pieces_near`]); every other point is held to
    /// the exact evaluator's own piece, with the same tolerances.
    pub fn check(&mut self, d: &Derivation, vol: &LatticeVolume, pts: &[[f32; 4]], values: &[f32], grads: &[[f32; 4]]) {
        let exact = cpu_eval(d, vol, pts);
        let data = |j: &[i64]| vol.get(j) as f64;
        for (((p, v), g), (ev, eg)) in pts.iter().zip(values).zip(grads).zip(&exact) {
            let mut err = self.errors(*v, g, *ev, eg);
            let x = [p[0] as f64, p[1] as f64, p[2] as f64];
            if let Some(tol) = near_knot(d, &x) {
                self.near_knot_points += 1;
                if !self.within(err) {
                    let other = d
                        .eval_f64_pieces_near(&x, &data, tol)
                        .iter()
                        .map(|(ov, og)| self.errors(*v, g, *ov, og))
                        .find(|e| self.within(*e));
                    if let Some(e) = other {
                        self.accepted_other_side += 1;
                        err = e;
                    }
                }
            }
            self.max_abs = self.max_abs.max(err.0);
            self.max_rel = self.max_rel.max(err.1);
        }
        self.points += pts.len();
    }

    /// Every point within the value and gradient tolerances.
    pub fn passed(&self) -> bool {
        self.max_abs <= VALUE_TOLERANCE * self.data_range && self.max_rel <= GRADIENT_TOLERANCE
    }
}
