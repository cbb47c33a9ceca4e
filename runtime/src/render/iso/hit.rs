//! The exact first-hit walk's plan: the planes that cut a ray into
//! polynomial pieces, Bernstein conversions and root isolation (shared by the
//! WGSL template and the CPU reference), and the template's context.

use boxforge::derive::Derivation;

/// Segments shorter than this (in cells) merge into the next one: planes
/// that cross the ray this close together are one cut (both walks).
pub const HIT_MERGE: f64 = 1e-5;
/// Deepest Bernstein subdivision level of the first-root search.
pub const HIT_DEPTH: i32 = 10;
/// Subdivision steps of the first-root search before it gives up (a miss).
pub const HIT_ITERATIONS: usize = 64;
/// Root tolerance in cells (as the fixed-step bisection).
pub const HIT_TOLERANCE: f64 = 1e-4;

/// What the exact first-hit walk needs from a filter: the planes that cut a
/// ray into polynomial pieces, and the conversion from samples on a segment
/// to the Bernstein coefficients of that piece.
#[derive(Clone, Debug)]
pub struct HitPlan {
    /// Plane families n . x in offset + period Z: the grid planes x_i in o_i + Z
    /// and every knot-plane family that is not an axis (axis knot planes are
    /// grid planes). Between two consecutive crossings the ray stays in one cell.
    pub families: Vec<([f64; 3], f64, f64)>,
    /// The grid offset o (cubes are o + z + `[0,1]^3`).
    pub grid_offset: [f64; 3],
    /// The filter's degree: the degree of the spline on every segment.
    pub degree: usize,
    /// Where a segment is sampled (u in `[0,1]`) and whether the sample also
    /// takes the derivative along the ray (from `_eval_grad`, which costs
    /// about one `_eval`): together degree + 1 conditions.
    pub samples: Vec<(f64, bool)>,
    /// Whether the samples start at u = 0 and end at u = 1, so that the end
    /// sample of one segment is the start sample of the next (continuous
    /// splines; with derivatives only for C^1 and smoother ones).
    pub shared_ends: bool,
    /// `to_bernstein[j][c]`: weight of condition c (each sample's value, then
    /// its derivative d/du if taken) in Bernstein coefficient j.
    pub to_bernstein: Vec<Vec<f64>>,
    /// For C^2 splines of even degree: the segment after an evaluated one
    /// may take the second derivative at its start from the previous
    /// segment's polynomial (the spline is C^2 across every plane), one
    /// sample fewer. `carried_samples` are its interior samples (value and
    /// derivative each), `carried_to_bernstein` the conversion of the
    /// conditions [v0, d0, s0 (d²/du²), interior..., v1, d1].
    pub carried_samples: Vec<f64>,
    /// See `carried_samples`; empty when segments never carry.
    pub carried_to_bernstein: Vec<Vec<f64>>,
    /// For filters whose unit cubes are single polynomial pieces and whose
    /// only cutting planes are the grid planes (cc_trilinear, cc_tricubic):
    /// the WGSL of `<f>_ray_bernstein`, which gives a segment's Bernstein
    /// coefficients from one set of fetches by blossoming instead of the
    /// samples above (`boxforge::emit::factored::ray_bernstein_fn`). The
    /// polynomial is the same; the CPU reference keeps sampling it.
    pub ray_bernstein: Option<String>,
}

/// A carried second derivative s = d²f/dt² passes from segment to segment
/// unchanged in t units (for Hermite data v0, d0, s0, v1, d1 the end value
/// p''(1) depends on s0 with weight exactly 1), so the rounding error that a
/// fresh or carried segment k puts into s, about e / len_k², reaches segment
/// m as e (len_m / len_k)² in its coefficients. A segment carries only while
/// len_m² * sum_k 1 / len_k² (over the chain since the last fresh segment)
/// stays at most this bound: the error stays within this many roundings of
/// one segment, whatever the segment lengths (a short segment makes the next
/// long one start fresh).
pub const HIT_CARRY_BOUND: f64 = 8.0;

impl HitPlan {
    /// The plan of a 3D filter. C^1 splines of degree >= 3 sample value and
    /// derivative at both ends and (n - 3) more conditions at interior
    /// Chebyshev points (Hermite data: about half the samples of values only);
    /// other continuous splines values at the Chebyshev extrema; discontinuous
    /// ones values at the Chebyshev roots inside (0,1), off the knot planes.
    pub fn new(d: &Derivation) -> HitPlan {
        let arr = &d.arrangement;
        let grid_offset = [0, 1, 2].map(|i| arr.grid_offset[i].to_f64());
        let mut families = grid_families(grid_offset);
        for f in &arr.families {
            if f.normal.iter().filter(|&&c| c != 0).count() > 1 {
                families.push(([0, 1, 2].map(|i| f.normal[i] as f64), f.offset.to_f64(), f.period as f64));
            }
        }
        let ray_bernstein =
            if families.len() == 3 { boxforge::emit::factored::ray_bernstein_fn(d, &d.filter.name) } else { None };
        HitPlan { ray_bernstein, ..HitPlan::with_families(d, families, grid_offset) }
    }

    /// The plan for these cutting planes: the sampling and conversions
    /// follow from the filter's degree and continuity alone.
    fn with_families(d: &Derivation, families: Vec<([f64; 3], f64, f64)>, grid_offset: [f64; 3]) -> HitPlan {
        let n = d.facts.degree;
        let pi = std::f64::consts::PI;
        let cheb = |k: usize, m: usize| 0.5 * (1.0 - (pi * k as f64 / m as f64).cos());
        let (samples, shared_ends): (Vec<(f64, bool)>, bool) = if d.facts.continuity >= 1 && n >= 3 {
            let r = n - 3;
            let m = r.div_ceil(2);
            let mut v = vec![(0.0, true)];
            v.extend((1..=m).map(|k| (cheb(k, m + 1), !(r % 2 == 1 && k == m))));
            v.push((1.0, true));
            (v, true)
        } else if d.facts.continuity >= 0 && n > 0 {
            ((0..=n).map(|i| (if i == n { 1.0 } else { cheb(i, n) }, false)).collect(), true)
        } else {
            (
                (0..=n).map(|i| (0.5 * (1.0 - (pi * (2 * i + 1) as f64 / (2 * n + 2) as f64).cos()), false)).collect(),
                false,
            )
        };
        let mut m: Vec<Vec<f64>> = Vec::new();
        for &(x, grad) in &samples {
            m.push((0..=n).map(|j| bernstein(n, j, x)).collect());
            if grad {
                m.push((0..=n).map(|j| bernstein_du(n, j, x)).collect());
            }
        }
        assert_eq!(m.len(), n + 1, "degree + 1 conditions");
        let (mut carried_samples, mut carried_to_bernstein) = (vec![], vec![]);
        if d.facts.continuity >= 2 && n >= 4 && n.is_multiple_of(2) {
            let k = (n - 4) / 2;
            carried_samples = (1..=k).map(|i| cheb(i, k + 1)).collect();
            let mut rows: Vec<Vec<f64>> = vec![
                (0..=n).map(|j| bernstein(n, j, 0.0)).collect(),
                (0..=n).map(|j| bernstein_du(n, j, 0.0)).collect(),
                (0..=n).map(|j| bernstein_du2(n, j, 0.0)).collect(),
            ];
            for &x in &carried_samples {
                rows.push((0..=n).map(|j| bernstein(n, j, x)).collect());
                rows.push((0..=n).map(|j| bernstein_du(n, j, x)).collect());
            }
            rows.push((0..=n).map(|j| bernstein(n, j, 1.0)).collect());
            rows.push((0..=n).map(|j| bernstein_du(n, j, 1.0)).collect());
            assert_eq!(rows.len(), n + 1, "degree + 1 conditions");
            carried_to_bernstein = invert(&rows);
        }
        HitPlan {
            ray_bernstein: None,
            families,
            grid_offset,
            degree: n,
            samples,
            shared_ends,
            to_bernstein: invert(&m),
            carried_samples,
            carried_to_bernstein,
        }
    }

    /// Bernstein coefficients on `[0,1]` from the conditions (values and
    /// derivatives d/du in the order of `samples`).
    pub fn coefficients(&self, conditions: &[f64]) -> Vec<f64> {
        self.coefficients_with(&self.to_bernstein, conditions)
    }

    /// Bernstein coefficients from conditions through a conversion matrix.
    pub fn coefficients_with(&self, m: &[Vec<f64>], conditions: &[f64]) -> Vec<f64> {
        m.iter().map(|row| row.iter().zip(conditions).map(|(w, v)| w * v).sum()).collect()
    }

    /// Samples per segment that call the evaluator (shared ends not counted).
    pub fn evals_per_segment(&self) -> usize {
        self.samples.len() - self.shared_ends as usize
    }
}

/// The grid planes x_i in o_i + Z of the three spatial axes.
fn grid_families(grid_offset: [f64; 3]) -> Vec<([f64; 3], f64, f64)> {
    (0..3)
        .map(|i| {
            let mut n = [0.0; 3];
            n[i] = 1.0;
            (n, grid_offset[i], 1.0)
        })
        .collect()
}

/// The exact first-hit plan of a 4D filter on the hyperplane t = T of a
/// time-varying volume. A 4D knot plane n . x in offset + period Z meets
/// that hyperplane in the 3D plane n_xyz . x in (offset - n_t T) + period Z,
/// so the families of the walk are those of the 4D arrangement whose normal
/// has a spatial part, their offsets moving with T (the shader adds n_t T
/// per ray); normals along t alone never cut a ray at fixed t, and the
/// spatial axes are grid planes. Between two crossings the ray stays in one
/// 4D cell, where the spline is one polynomial of the filter's degree.
#[derive(Clone, Debug)]
pub struct TimeHitPlan {
    /// The plan with the families' offsets at T = 0.
    pub plan: HitPlan,
    /// n_t of each family of `plan.families` (0 for the grid planes).
    pub time_normals: Vec<f64>,
}

impl TimeHitPlan {
    /// The plan of a 4D filter (None for other dimensions).
    pub fn new(d: &Derivation) -> Option<TimeHitPlan> {
        let arr = &d.arrangement;
        if arr.grid_offset.len() != 4 {
            return None;
        }
        let grid_offset = [0, 1, 2].map(|i| arr.grid_offset[i].to_f64());
        let mut families = grid_families(grid_offset);
        let mut time_normals = vec![0.0; 3];
        for f in &arr.families {
            let spatial = f.normal[..3].iter().filter(|&&c| c != 0).count();
            if spatial > 0 && f.normal.iter().filter(|&&c| c != 0).count() > 1 {
                families.push(([0, 1, 2].map(|i| f.normal[i] as f64), f.offset.to_f64(), f.period as f64));
                time_normals.push(f.normal[3] as f64);
            }
        }
        // Every segment is sampled afresh: no carried second derivatives
        // (the 4D walk samples in one loop, see templates/four_hit.wgsl.j2).
        let plan = HitPlan {
            carried_samples: vec![],
            carried_to_bernstein: vec![],
            ..HitPlan::with_families(d, families, grid_offset)
        };
        Some(TimeHitPlan { plan, time_normals })
    }

    /// The 3D plan at time `t`: the families' offsets moved to t.
    pub fn at(&self, t: f64) -> HitPlan {
        let mut plan = self.plan.clone();
        for ((_, off, _), nt) in plan.families.iter_mut().zip(&self.time_normals) {
            *off -= nt * t;
        }
        plan
    }
}

/// The Bernstein basis polynomial B_j^n(x).
fn bernstein(n: usize, j: usize, x: f64) -> f64 {
    let mut binom = 1.0;
    for k in 0..j {
        binom = binom * (n - k) as f64 / (k + 1) as f64;
    }
    binom * x.powi(j as i32) * (1.0 - x).powi((n - j) as i32)
}

/// d²/dx² B_j^n(x) = n (n - 1) (B_{j-2}^{n-2} - 2 B_{j-1}^{n-2} + B_j^{n-2})(x).
fn bernstein_du2(n: usize, j: usize, x: f64) -> f64 {
    let b = |k: i64| if k >= 0 && k as usize <= n - 2 { bernstein(n - 2, k as usize, x) } else { 0.0 };
    let j = j as i64;
    (n * (n - 1)) as f64 * (b(j - 2) - 2.0 * b(j - 1) + b(j))
}

/// The second derivative d²/dt² at the end of a segment of length `len`
/// from the Bernstein coefficients of its polynomial (in u).
pub fn end_second_derivative(c: &[f64], len: f64) -> f64 {
    let n = c.len() - 1;
    (n * (n - 1)) as f64 * (c[n] - 2.0 * c[n - 1] + c[n - 2]) / (len * len)
}

/// d/dx B_j^n(x) = n (B_{j-1}^{n-1}(x) - B_j^{n-1}(x)).
fn bernstein_du(n: usize, j: usize, x: f64) -> f64 {
    let lower = |k: usize| if k < n { bernstein(n - 1, k, x) } else { 0.0 };
    let left = if j > 0 { lower(j - 1) } else { 0.0 };
    n as f64 * (left - lower(j))
}

/// The inverse of a small well-conditioned matrix (Gauss-Jordan, partial pivoting).
fn invert(m: &[Vec<f64>]) -> Vec<Vec<f64>> {
    let n = m.len();
    let mut a: Vec<Vec<f64>> = m
        .iter()
        .enumerate()
        .map(|(i, row)| {
            let mut r = row.clone();
            r.extend((0..n).map(|j| (i == j) as i32 as f64));
            r
        })
        .collect();
    for col in 0..n {
        let piv = (col..n).max_by(|&x, &y| a[x][col].abs().total_cmp(&a[y][col].abs())).expect("rows");
        a.swap(col, piv);
        let p = a[col][col];
        for v in a[col].iter_mut() {
            *v /= p;
        }
        let pivot = a[col].clone();
        for (r, row) in a.iter_mut().enumerate() {
            let f = row[col];
            if r != col && f != 0.0 {
                for (x, p) in row.iter_mut().zip(&pivot) {
                    *x -= f * p;
                }
            }
        }
    }
    a.into_iter().map(|r| r[n..].to_vec()).collect()
}

/// The polynomial with Bernstein coefficients `c` on `[0,1]` at u (de Casteljau).
pub fn bernstein_at(c: &[f64], u: f64) -> f64 {
    let mut b = c.to_vec();
    for r in 1..b.len() {
        for j in 0..b.len() - r {
            b[j] = (1.0 - u) * b[j] + u * b[j + 1];
        }
    }
    b[0]
}

/// The Bernstein coefficients of the same polynomial on [u0, u1] (0 < u1).
pub fn bernstein_restrict(c: &[f64], u0: f64, u1: f64) -> Vec<f64> {
    let n = c.len() - 1;
    let mut b = c.to_vec();
    let mut left = vec![0.0; n + 1];
    left[0] = b[0];
    for (r, l) in left.iter_mut().enumerate().skip(1) {
        for j in 0..=n - r {
            b[j] = (1.0 - u1) * b[j] + u1 * b[j + 1];
        }
        *l = b[0];
    }
    let s = u0 / u1;
    let mut out = vec![0.0; n + 1];
    out[n] = left[n];
    for r in 1..=n {
        for j in 0..=n - r {
            left[j] = (1.0 - s) * left[j] + s * left[j + 1];
        }
        out[n - r] = left[n - r];
    }
    out
}

/// Sign changes (negative vs not) along the coefficients.
fn variations(c: &[f64]) -> usize {
    c.windows(2).filter(|w| (w[0] < 0.0) != (w[1] < 0.0)).count()
}

/// The first root in `[0,1]` of the polynomial with Bernstein coefficients
/// `c` (of f - iso), to `tol` in u: depth-first, left-first over dyadic
/// intervals, an interval is dropped when its coefficients have one sign,
/// accepted when they change sign once (exactly one root), split otherwise
/// down to [`HIT_DEPTH`]; the root is then bisected on the polynomial. The
/// shader's `_first_root` is the same algorithm in f32.
pub fn first_root(c: &[f64], tol: f64) -> Option<f64> {
    let n = c.len() - 1;
    let (mut l, mut k) = (0i32, 0i64);
    for _ in 0..HIT_ITERATIONS {
        let w = 1.0 / (1i64 << l) as f64;
        let u0 = k as f64 * w;
        let s = if l == 0 { c.to_vec() } else { bernstein_restrict(c, u0, (k + 1) as f64 * w) };
        let v = variations(&s);
        let mut done = v == 0;
        if v == 1 || (v > 0 && l == HIT_DEPTH) {
            if (s[0] < 0.0) != (s[n] < 0.0) {
                let (mut a, mut b) = (0.0, 1.0);
                let sa = s[0] < 0.0;
                for _ in 0..40 {
                    if (b - a) * w <= tol {
                        break;
                    }
                    let m = 0.5 * (a + b);
                    if (bernstein_at(&s, m) < 0.0) == sa {
                        a = m;
                    } else {
                        b = m;
                    }
                }
                return Some(u0 + w * 0.5 * (a + b));
            }
            done = true;
        }
        if !done {
            l += 1;
            k *= 2;
            continue;
        }
        loop {
            if l == 0 {
                return None;
            }
            if k & 1 == 0 {
                k += 1;
                break;
            }
            k >>= 1;
            l -= 1;
        }
    }
    None
}

/// The next t > `t` where a ray with a = n . origin - offset and b = n . dir
/// crosses a plane of a family with this period (infinite when parallel).
pub(crate) fn next_crossing(a: f64, b: f64, period: f64, t: f64) -> f64 {
    if b.abs() <= 1e-9 {
        return f64::INFINITY;
    }
    let q = (a + t * b) / period;
    let k = if b > 0.0 { q.floor() + 1.0 } else { q.ceil() - 1.0 };
    (k * period - a) / b
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::render::iso::cpu::hit_exact;
    use crate::volume::LatticeVolume;
    use glam::DVec3;

    fn derive(name: &str) -> Derivation {
        Derivation::new(&boxforge::spec::catalog::get(name).unwrap()).unwrap()
    }

    #[test]
    fn conversions_reproduce_a_polynomial_from_its_conditions() {
        for name in ["bcc7", "cc_tricubic", "fcc6", "bcc_linear", "bcc8"] {
            let plan = HitPlan::new(&derive(name));
            let n = plan.degree;
            let b: Vec<f64> = (0..=n).map(|j| ((j * 7 + 3) % 5) as f64 - 2.0 + 0.1 * j as f64).collect();
            let h = 1e-5;
            let val = |u: f64| bernstein_at(&b, u);
            let du = |u: f64| (val(u + h) - val(u - h)) / (2.0 * h);
            let du2 = |u: f64| (val(u + h) - 2.0 * val(u) + val(u - h)) / (h * h);
            let mut cond = vec![];
            for &(u, grad) in &plan.samples {
                cond.push(val(u));
                if grad {
                    cond.push(du(u));
                }
            }
            let c = plan.coefficients(&cond);
            for (x, y) in c.iter().zip(&b) {
                assert!((x - y).abs() < 1e-6, "{name}: {c:?} vs {b:?}");
            }
            if !plan.carried_to_bernstein.is_empty() {
                let mut cond = vec![val(0.0), du(0.0), du2(0.0)];
                for &u in &plan.carried_samples {
                    cond.extend([val(u), du(u)]);
                }
                cond.extend([val(1.0), du(1.0)]);
                let c = plan.coefficients_with(&plan.carried_to_bernstein, &cond);
                for (x, y) in c.iter().zip(&b) {
                    assert!((x - y).abs() < 1e-3, "{name} carried: {c:?} vs {b:?}");
                }
                let s = end_second_derivative(&b, 2.0);
                assert!((s - du2(1.0) / 4.0).abs() < 1e-3, "{s} vs {}", du2(1.0) / 4.0);
            }
        }
    }

    #[test]
    fn first_root_finds_the_first_of_several_roots() {
        // (u - 0.3)(u - 0.35)(u - 0.8) in Bernstein form via samples.
        let p = |u: f64| (u - 0.3) * (u - 0.35) * (u - 0.8);
        let n = 3;
        let nodes: Vec<f64> = (0..=n).map(|i| i as f64 / n as f64).collect();
        let m: Vec<Vec<f64>> = nodes.iter().map(|&x| (0..=n).map(|j| bernstein(n, j, x)).collect()).collect();
        let inv = invert(&m);
        let v: Vec<f64> = nodes.iter().map(|&x| p(x)).collect();
        let c: Vec<f64> = inv.iter().map(|r| r.iter().zip(&v).map(|(a, b)| a * b).sum()).collect();
        let u = first_root(&c, 1e-9).unwrap();
        assert!((u - 0.3).abs() < 1e-8, "{u}");
        // Two close roots only: none when the polynomial stays positive.
        let q = |u: f64| (u - 0.5).powi(2) + 1e-3;
        let v: Vec<f64> = nodes.iter().map(|&x| q(x)).collect();
        let c: Vec<f64> = inv.iter().map(|r| r.iter().zip(&v).map(|(a, b)| a * b).sum()).collect();
        assert_eq!(first_root(&c, 1e-9), None);
    }

    /// Between two crossings of a 4D plan at time t the exact evaluator is
    /// one polynomial of the filter's degree along the ray (the fit through
    /// degree + 1 points predicts others), on arbitrary data, for the grid
    /// planes of Z^4 and the time-slanted knot planes of D4*; with the
    /// traces of the planes at another time (D4*) it is not.
    #[test]
    fn a_4d_plan_cuts_rays_where_the_pieces_change() {
        assert!(TimeHitPlan::new(&derive("bcc7")).is_none());
        for name in ["z4_linear", "d4star8"] {
            let d = derive(name);
            let time_plan = TimeHitPlan::new(&d).unwrap();
            let data = |j: &[i64]| {
                let h = j.iter().fold(17u64, |h, &x| h.wrapping_mul(0x9e37_79b9_7f4a_7c15).wrapping_add(x as u64 + 3));
                ((h >> 33) % 1000) as f64 / 1000.0
            };
            let t = 5.37;
            let f = |x: DVec3| d.eval_f64(&[x.x, x.y, x.z, t], &data).0;
            let origin = DVec3::new(5.1, 4.3, 6.2);
            let dir = DVec3::new(0.71, 0.43, 0.37).normalize();
            // Whether every segment between the plan's crossings is one polynomial.
            let pieces_fit = |plan: &HitPlan| -> bool {
                let n = plan.degree;
                let fam: Vec<(f64, f64, f64)> = plan
                    .families
                    .iter()
                    .map(|(nv, off, g)| (DVec3::from_array(*nv).dot(origin) - off, DVec3::from_array(*nv).dot(dir), *g))
                    .collect();
                let mut a = 0.0;
                while a < 4.0 {
                    let b = fam.iter().map(|&(p, q, g)| next_crossing(p, q, g, a + 1e-9)).fold(f64::INFINITY, f64::min);
                    let xs: Vec<f64> = (0..=n).map(|i| 0.05 + 0.9 * i as f64 / n as f64).collect();
                    let ys: Vec<f64> = xs.iter().map(|&u| f(origin + (a + (b - a) * u) * dir)).collect();
                    let m: Vec<Vec<f64>> = xs.iter().map(|&x| (0..=n).map(|j| bernstein(n, j, x)).collect()).collect();
                    let c: Vec<f64> = invert(&m).iter().map(|r| r.iter().zip(&ys).map(|(w, y)| w * y).sum()).collect();
                    for u in [0.0, 0.13, 0.51, 0.88, 1.0] {
                        if (bernstein_at(&c, u) - f(origin + (a + (b - a) * u) * dir)).abs() > 1e-9 {
                            return false;
                        }
                    }
                    a = b;
                }
                true
            };
            assert!(pieces_fit(&time_plan.at(t)), "{name}: one polynomial between crossings");
            if name == "d4star8" {
                assert!(time_plan.time_normals.iter().any(|&n| n != 0.0), "slanted in time");
                assert!(!pieces_fit(&time_plan.at(t - 0.5)), "{name}: the planes move with t");
            }
        }
    }

    #[test]
    fn carried_second_derivatives_give_the_hits_of_fresh_samples() {
        let d = derive("bcc7");
        let vol = LatticeVolume::marschner_lobb(&d.filter.lattice, [24; 3]).unwrap();
        let data = |j: &[i64]| vol.get(j) as f64;
        let f = |x: DVec3| d.eval_f64(&x.to_array(), &data);
        let plan = HitPlan::new(&d);
        assert!(!plan.carried_to_bernstein.is_empty());
        let fresh = HitPlan { carried_to_bernstein: vec![], ..plan.clone() };
        let mut hits = 0;
        for k in 0..40 {
            let a = 0.3 + 0.05 * k as f64;
            let dir = DVec3::new(a.cos() * 0.9, a.sin() * 0.9, -0.43).normalize();
            let origin = DVec3::new(11.5, 11.7, 11.3) - 9.0 * dir;
            let x = hit_exact(&f, &plan, origin, dir, 0.0, 18.0, 0.5);
            let y = hit_exact(&f, &fresh, origin, dir, 0.0, 18.0, 0.5);
            assert_eq!(x.is_some(), y.is_some(), "ray {k}: {x:?} vs {y:?}");
            if let (Some(x), Some(y)) = (x, y) {
                assert!((x - y).abs() < 1e-3, "ray {k}: {x} vs {y}");
                hits += 1;
            }
        }
        assert!(hits > 10, "{hits}");
    }
}
