//! Factorisation of tensor-product box splines (docs/EVALUATION_FORMS.md §3).
//!
//! When every direction is parallel to a coordinate axis, the box spline is
//! a product of one-dimensional box splines, one per axis: for n_i copies of
//! a_i e_i, M_i(t) = B_{n_i}(t / a_i) / a_i with B_n the cardinal B-spline of
//! order n. If moreover a_i e_i lies in the lattice L, then L is a union of
//! cosets v + diag(a) Z^s, and on each coset the spline is a tensor product:
//!
//!   s(x) = |det G| / prod a_i * sum_v sum_m c_{v + a m} prod_i B_{n_i}(s_i - m_i),
//!   s_i = (x_i - v_i) / a_i + n_i / 2.
//!
//! With f = floor(s) and t = s - f, sample m_i = f_i - k has weight
//! B_n(t + k), a polynomial piece in t. The pieces are derived here exactly
//! by repeated convolution of the box (B_{n+1}(x) = int_{x-1}^x B_n), from the
//! directions alone; the tests check the product against the PP-form.

use crate::derive::Derivation;
use crate::math::exact::Q;
use crate::math::linalg::IVec;
use crate::spec::Filter;

/// One axis of a tensor-product filter.
#[derive(Clone, Debug, PartialEq)]
pub struct AxisFactor {
    /// Length a of the directions along this axis (the coset spacing).
    pub step: i64,
    /// Number n of directions along this axis (B-spline order; degree n - 1).
    pub order: usize,
    /// `pieces[k]` = coefficients (power basis in t) of B_n(t + k), t in [0, 1):
    /// the weight of the sample k steps below floor(s).
    pub pieces: Vec<Vec<Q>>,
}

/// The tensor-product structure of a filter, when it has one.
#[derive(Clone, Debug, PartialEq)]
pub struct Factorisation {
    /// One factor per coordinate axis, in axis order.
    pub axes: Vec<AxisFactor>,
    /// Representatives of the cosets of diag(a) Z^s in L, in [0, a_i).
    pub cosets: Vec<IVec>,
    /// |det G| / prod a_i.
    pub scale: Q,
}

/// Pieces of the cardinal B-spline of order n: `out[k]` is B_n(k + t) in
/// the power basis of t in [0, 1).
pub fn cardinal_bspline_pieces(n: usize) -> Vec<Vec<Q>> {
    let mut pieces: Vec<Vec<Q>> = vec![vec![Q::one()]];
    for order in 1..n {
        // I_j(t) = int_0^t Q_j, with Q_j the piece on [j, j+1).
        let integral = |p: &Vec<Q>| -> Vec<Q> {
            let mut out = vec![Q::zero()];
            for (e, c) in p.iter().enumerate() {
                out.push(c.clone() / Q::int(e as i64 + 1));
            }
            out
        };
        let ints: Vec<Vec<Q>> = pieces.iter().map(integral).collect();
        let at_one = |p: &Vec<Q>| -> Q { p.iter().cloned().sum() };
        // B_{order+1}(k + t) = I_{k-1}(1) - I_{k-1}(t) + I_k(t).
        let mut next = Vec::new();
        for k in 0..=order {
            let mut p = vec![Q::zero(); order + 1];
            if k >= 1 {
                let prev = &ints[k - 1];
                p[0] += &at_one(prev);
                for (e, c) in prev.iter().enumerate() {
                    p[e] -= c;
                }
            }
            if k < order {
                for (e, c) in ints[k].iter().enumerate() {
                    p[e] += c;
                }
            }
            next.push(p);
        }
        pieces = next;
    }
    pieces
}

impl Factorisation {
    /// The factorisation of `filter`, or None when some direction is not
    /// axis-aligned, an axis mixes direction lengths, or a_i e_i is not in L.
    pub fn of(filter: &Filter) -> Option<Factorisation> {
        let s = filter.dim();
        let mut steps: Vec<Option<i64>> = vec![None; s];
        let mut orders = vec![0usize; s];
        for d in &filter.directions {
            let nz: Vec<usize> = (0..s).filter(|&i| d[i] != 0).collect();
            if nz.len() != 1 {
                return None;
            }
            let (i, a) = (nz[0], d[nz[0]].abs());
            match steps[i] {
                None => steps[i] = Some(a),
                Some(b) if b == a => {}
                Some(_) => return None,
            }
            orders[i] += 1;
        }
        let steps: Vec<i64> = steps.into_iter().collect::<Option<Vec<_>>>()?;
        let lattice = &filter.lattice;
        for i in 0..s {
            let mut e = vec![0; s];
            e[i] = steps[i];
            if !lattice.contains(&e) {
                return None;
            }
        }
        // Cosets: lattice points of the box prod [0, a_i).
        let mut cosets = Vec::new();
        let mut v = vec![0i64; s];
        loop {
            if lattice.contains(&v) {
                cosets.push(v.clone());
            }
            let mut k = 0;
            loop {
                if k == s {
                    let prod: i64 = steps.iter().product();
                    let scale = Q::frac(lattice.det(), prod);
                    let axes = (0..s)
                        .map(|i| AxisFactor {
                            step: steps[i],
                            order: orders[i],
                            pieces: cardinal_bspline_pieces(orders[i]),
                        })
                        .collect();
                    return Some(Factorisation { axes, cosets, scale });
                }
                v[k] += 1;
                if v[k] < steps[k] {
                    break;
                }
                v[k] = 0;
                k += 1;
            }
        }
    }

    /// Whether every knot lies on a face of the unit cubes [z, z+1] (a_i n_i
    /// even on every axis), so each coset is one polynomial piece per cube.
    pub fn knots_on_cube_faces(&self) -> bool {
        self.axes.iter().all(|a| (a.step * a.order as i64) % 2 == 0)
    }

    /// Whether hardware linear filtering can replace pairs of exact loads:
    /// one coset with unit steps (adjacent samples are adjacent texels of
    /// the embedded texture), and every weight piece provably non-negative
    /// on [0, 1] (all its Bernstein coefficients >= 0, checked exactly).
    pub fn supports_linear_fetch(&self) -> bool {
        self.cosets.len() == 1
            && self.axes.iter().all(|a| a.step == 1)
            && self.axes.iter().all(|a| a.pieces.iter().all(|p| bernstein_01(p).iter().all(|b| !b.is_negative())))
    }

    /// Hardware-filtered fetches per evaluation: ceil(n_i / 2) per axis.
    pub fn linear_fetches(&self) -> usize {
        self.axes.iter().map(|a| a.order.div_ceil(2)).product()
    }

    /// The linear-fetch evaluation in f64, as a GPU computes it: per axis,
    /// pairs (k, k+1) of samples become one fetch at f - k - w_{k+1}/(w_k +
    /// w_{k+1}) with weight w_k + w_{k+1}, then the hardware interpolates the
    /// 2^s texels around each fetch position. `frac_bits`: round the
    /// interpolation fraction to that many bits (CUDA documents 8 fractional
    /// bits for its texture filtering weights; None: exact).
    pub fn eval_linear_f64(&self, x: &[f64], data: &dyn Fn(&[i64]) -> f64, frac_bits: Option<u32>) -> f64 {
        let s = self.axes.len();
        let v = &self.cosets[0];
        // Per axis: (position, weight) of each fetch.
        let mut fetches: Vec<Vec<(f64, f64)>> = Vec::new();
        for i in 0..s {
            let a = &self.axes[i];
            let si = (x[i] - v[i] as f64) / a.step as f64 + a.order as f64 / 2.0;
            let f = si.floor();
            let t = si - f;
            let w: Vec<f64> =
                a.pieces.iter().map(|p| p.iter().rev().fold(0.0, |acc, c| acc * t + c.to_f64())).collect();
            let mut axis = Vec::new();
            let mut k = 0;
            while k < a.order {
                let pos0 = v[i] as f64 + a.step as f64 * (f - k as f64);
                if k + 1 < a.order {
                    let g = w[k] + w[k + 1];
                    let h = if g > 0.0 { w[k + 1] / g } else { 0.0 };
                    axis.push((pos0 - h * a.step as f64, g));
                } else {
                    axis.push((pos0, w[k]));
                }
                k += 2;
            }
            fetches.push(axis);
        }
        let counts: Vec<usize> = fetches.iter().map(|f| f.len()).collect();
        let mut total = 0.0;
        for idx in odometer(&counts) {
            let mut weight = self.scale.to_f64();
            let mut pos = vec![0.0; s];
            for i in 0..s {
                let (p, g) = fetches[i][idx[i]];
                weight *= g;
                pos[i] = p;
            }
            // Hardware interpolation between the texels around pos.
            let base: Vec<i64> = pos.iter().map(|p| p.floor() as i64).collect();
            let frac: Vec<f64> = pos
                .iter()
                .zip(&base)
                .map(|(p, b)| {
                    let f = p - *b as f64;
                    match frac_bits {
                        Some(bits) => (f * (1u64 << bits) as f64).round() / (1u64 << bits) as f64,
                        None => f,
                    }
                })
                .collect();
            let mut value = 0.0;
            for corner in odometer(&vec![2; s]) {
                let j: Vec<i64> = (0..s).map(|i| base[i] + corner[i] as i64).collect();
                let w: f64 = (0..s).map(|i| if corner[i] == 1 { frac[i] } else { 1.0 - frac[i] }).product();
                if w != 0.0 {
                    value += w * data(&j);
                }
            }
            total += weight * value;
        }
        total
    }

    /// Samples per evaluation: cosets x prod n_i.
    pub fn fetches(&self) -> usize {
        self.cosets.len() * self.axes.iter().map(|a| a.order).product::<usize>()
    }

    /// Exact evaluation (the CPU mirror of the emitted code).
    ///
    /// # Panics
    ///
    /// If a coordinate of `x` is beyond the i64 range.
    pub fn eval_exact(&self, x: &[Q], data: &dyn Fn(&[i64]) -> Q) -> Q {
        let s = self.axes.len();
        let mut total = Q::zero();
        for v in &self.cosets {
            // Per axis: base sample and weights.
            let mut base = vec![0i64; s];
            let mut weights: Vec<Vec<Q>> = Vec::new();
            for i in 0..s {
                let a = &self.axes[i];
                let si = (&x[i] - &Q::int(v[i])) / Q::int(a.step) + Q::frac(a.order as i64, 2);
                let f = si.floor();
                let t = &si - &f;
                base[i] =
                    v[i] + a.step * f.to_i64().expect("x is within the i64 range (the precondition of eval_exact)");
                weights.push(a.pieces.iter().map(|p| p.iter().rev().fold(Q::zero(), |acc, c| acc * &t + c)).collect());
            }
            let orders: Vec<usize> = self.axes.iter().map(|a| a.order).collect();
            for k in odometer(&orders) {
                let j: IVec = (0..s).map(|i| base[i] - self.axes[i].step * k[i] as i64).collect();
                let w = (0..s).fold(Q::one(), |w, i| w * &weights[i][k[i]]);
                if !w.is_zero() {
                    total += &(w * data(&j));
                }
            }
        }
        total * &self.scale
    }
}

/// Bernstein coefficients over [0, 1] of sum_e c_e t^e (degree len - 1).
pub fn bernstein_01(coeffs: &[Q]) -> Vec<Q> {
    use crate::math::exact::binomial;
    let deg = coeffs.len().saturating_sub(1);
    (0..=deg)
        .map(|j| {
            (0..=j).map(|e| coeffs[e].clone() * binomial(j as u32, e as u32) / binomial(deg as u32, e as u32)).sum()
        })
        .collect()
}

/// Every multi-index k with 0 <= k_i < n_i, first index fastest.
pub fn odometer(n: &[usize]) -> Vec<Vec<usize>> {
    let total: usize = n.iter().product();
    (0..total)
        .map(|mut r| {
            n.iter()
                .map(|&ni| {
                    let d = r % ni;
                    r /= ni;
                    d
                })
                .collect()
        })
        .collect()
}

impl Derivation {
    /// The tensor-product factorisation of this filter, when it has one.
    pub fn factorisation(&self) -> Option<Factorisation> {
        Factorisation::of(&self.filter)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::spec::catalog;

    #[test]
    fn cubic_pieces_are_the_cardinal_cubic_bspline() {
        // B_4 on [0,1): t^3/6; the pieces sum to one (partition of unity)
        // and are C^2 across integer knots.
        let p = cardinal_bspline_pieces(4);
        assert_eq!(p.len(), 4);
        assert_eq!(p[0], vec![Q::zero(), Q::zero(), Q::zero(), Q::frac(1, 6)]);
        for e in 0..4 {
            let sum: Q = p.iter().map(|q| q[e].clone()).sum();
            assert_eq!(sum, if e == 0 { Q::one() } else { Q::zero() });
        }
        let at = |q: &Vec<Q>, t: &Q| q.iter().rev().fold(Q::zero(), |acc, c| acc * t + c);
        for k in 0..3 {
            assert_eq!(at(&p[k], &Q::one()), at(&p[k + 1], &Q::zero()));
        }
    }

    #[test]
    fn factorised_evaluation_equals_the_pp_form() {
        for name in ["cc_tricubic", "cc_trilinear", "bcc12"] {
            let f = catalog::get(name).unwrap();
            let fac = Factorisation::of(&f).expect("tensor product");
            let d = Derivation::new(&f).unwrap();
            let data = |j: &[i64]| Q::int((j[0] * 7 + j[1] * 3 - j[2] * 5).rem_euclid(11) - 4);
            for i in 0..12 {
                let x: Vec<Q> = (0..3).map(|c| Q::frac(((i * 37 + c * 101) % 97) as i64 - 40, 29)).collect();
                assert_eq!(fac.eval_exact(&x, &data), d.eval_exact(&x, &data), "{name} at {x:?}");
            }
        }
        // Linear fetches: exact for cc (one coset, unit steps), refused on bcc.
        let tc = Factorisation::of(&catalog::get("cc_tricubic").unwrap()).unwrap();
        assert!(tc.supports_linear_fetch() && tc.linear_fetches() == 8);
        assert!(!Factorisation::of(&catalog::get("bcc12").unwrap()).unwrap().supports_linear_fetch());
        let dataf = |j: &[i64]| ((j[0] * 7 + j[1] * 3 - j[2] * 5).rem_euclid(11) - 4) as f64;
        let dataq = |j: &[i64]| Q::int((j[0] * 7 + j[1] * 3 - j[2] * 5).rem_euclid(11) - 4);
        let mut worst8: f64 = 0.0;
        for i in 0..20 {
            let x: Vec<f64> = (0..3).map(|c| ((i * 37 + c * 101) % 97) as f64 / 9.7 - 3.0).collect();
            let xq: Vec<Q> = x.iter().map(|v| Q::frac((v * 1e6).round() as i64, 1_000_000)).collect();
            let xr: Vec<f64> = xq.iter().map(|q| q.to_f64()).collect();
            let exact = tc.eval_exact(&xq, &dataq).to_f64();
            assert!((tc.eval_linear_f64(&xr, &dataf, None) - exact).abs() < 1e-9);
            worst8 = worst8.max((tc.eval_linear_f64(&xr, &dataf, Some(8)) - exact).abs());
        }
        // 8-bit weights cost accuracy (data range 10): visible, but bounded.
        assert!(worst8 > 1e-6 && worst8 < 0.2, "{worst8}");
        for name in ["bcc7", "fcc6", "zp"] {
            assert!(Factorisation::of(&catalog::get(name).unwrap()).is_none(), "{name}");
        }
    }
}
