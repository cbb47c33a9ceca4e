//! Integer tables that make one local piece cost microseconds instead of
//! milliseconds (issue: "any direction matrix in seconds").
//!
//! A local piece is `scale * sum over cone terms i and shifts sigma with
//! V_i^-1 (p - sigma) > 0` of `coef_i w_sigma prod_v (V_i^-1 (u + b - sigma))_v^p_v`
//! (see [`super::pieces`]). Written with the integer matrix `A_i = D_i V_i^-1`
//! and `b = B / q`, every factor is `(q A_iv . u + R_v) / (q D_i)` with the
//! integer `R_v = A_iv . B - q A_iv . sigma`, so the sum over shifts is an
//! integer tensor `T_i[k] = sum_sigma w_sigma prod_v C(p_v, k_v) R_v^(p_v - k_v)`
//! and the piece is `sum_i c_i sum_k T_i[k] q^|k| N_ik(u)` with fixed integer
//! polynomials `N_ik = prod_v (A_iv . u)^k_v` and one rational `c_i` per term.
//! The cone test is an integer sign test on `A_i Y - q' A_i sigma` (`Y / q'`:
//! the cell's interior point). Everything is checked `i128`; on overflow the
//! caller falls back to the rational path, so the result is exact either way.

use crate::derive::cone::ConeTerm;
use crate::math::exact::Q;
use crate::math::linalg::{IVec, QVec};
use crate::math::poly::{Monomials, Poly};
use crate::math::scaled::{integer, lcm, mul_add, ratio, small, Scaled};
use std::sync::Arc;

/// The integer tables of every cone term, for the fast path of local pieces.
#[derive(Debug)]
pub struct PieceTables {
    nvars: usize,
    degree: usize,
    terms: Vec<TermTable>,
}

#[derive(Debug)]
struct TermTable {
    /// Rows A_v = D V^-1 (integers).
    rows: Vec<Vec<i128>>,
    /// D > 0.
    denominator: i128,
    powers: Vec<u32>,
    /// Tensor dimensions p_v + 1 (row-major, last basis vector fastest).
    dims: Vec<usize>,
    /// S = A sigma for every shift, flattened [shift][v], the shifts sorted
    /// by S_0 so that the cone test `S_0 < (A y)_0` selects a prefix.
    shift_dots: Vec<i64>,
    /// Moment contributions `w_sigma prod_v S_v^m_v` per shift (same order),
    /// flattened [shift][tensor index m].
    moments: Vec<i128>,
    /// C(p_v, k) per basis vector v.
    binomials: Vec<Vec<i128>>,
    /// N_l for every tensor index l: `prod_v (A_v . u)^l_v`, integer
    /// coefficients over `Monomials(nvars, degree)`.
    images: Vec<Vec<i128>>,
    /// (p - k) as a tensor index, and sign (-1)^|p - k|, per tensor index k.
    complement: Vec<(usize, bool)>,
    /// |k| per tensor index k.
    index_degree: Vec<u32>,
    coef: Q,
}

impl PieceTables {
    /// The tables of a PP-form's cone terms and merged shifts `(sigma, w_sigma)`
    /// in dimension `dim` with pieces of degree `degree`, or `None` when some
    /// entry does not fit `i128`. It takes the parts rather than the PP-form
    /// because the PP-form owns the tables.
    pub fn new(terms: &[ConeTerm], shifts: &[(IVec, Q)], dim: usize, degree: usize) -> Option<Arc<PieceTables>> {
        let weights = shifts.iter().map(|(_, w)| integer(w)).collect::<Option<Vec<i128>>>()?;
        let shifts: Vec<Vec<i128>> = shifts.iter().map(|(s, _)| s.iter().map(|&x| x as i128).collect()).collect();
        let terms = terms
            .iter()
            .map(|t| TermTable::new(t, &shifts, &weights, dim, degree))
            .collect::<Option<Vec<TermTable>>>()?;
        Some(Arc::new(PieceTables { nvars: dim, degree, terms }))
    }

    /// The polynomial of `u -> phi(u + base)` on the region of phi that holds
    /// `point` (both already in the truncated powers' coordinates y = x - j + c),
    /// times `scale`; `None` on i128 overflow.
    pub fn piece(&self, base: &[Q], point: &[Q], scale: &Q) -> Option<Poly> {
        let s = self.nvars;
        let b = Scaled::from_q(base)?;
        let y = Scaled::from_q(point)?;
        let basis = Monomials::get(s, self.degree);
        let mut total = vec![0i128; basis.len()];
        let mut per_term: Vec<(Q, Vec<i128>)> = Vec::new();
        let mut bound = vec![0i64; s];
        let mut moment: Vec<i128> = Vec::new();
        let mut tensor: Vec<i128> = Vec::new();
        let mut next: Vec<i128> = Vec::new();
        for term in &self.terms {
            // Cone test t_v > 0  <=>  S_v < (A Y)_v / q'  <=>  S_v <= floor(((A Y)_v - 1) / q').
            for v in 0..s {
                let ay = dot(&term.rows[v], &y.numerators)?;
                let f = (ay - 1).div_euclid(y.denominator);
                bound[v] = f.clamp(i64::MIN as i128, i64::MAX as i128) as i64;
            }
            let size = term.images.len();
            let count = term.shift_dots.len() / s;
            let prefix = partition_point(count, |i| term.shift_dots[i * s] <= bound[0]);
            moment.clear();
            moment.resize(size, 0);
            let mut any = false;
            for i in 0..prefix {
                let sd = &term.shift_dots[i * s..(i + 1) * s];
                if (1..s).any(|v| sd[v] > bound[v]) {
                    continue;
                }
                any = true;
                for (m, c) in moment.iter_mut().zip(&term.moments[i * size..(i + 1) * size]) {
                    *m = m.checked_add(*c)?;
                }
            }
            if !any {
                continue;
            }
            // Coefficients of prod_v z_v^k_v, z_v = A_v . u + X_v / q, times q^(degree - |k|):
            // c_k = prod C(p_v, k_v) (-1)^|p-k| mu[p - k] q^(degree - |k|).
            tensor.clear();
            for (k, &(m, negative)) in term.complement.iter().enumerate() {
                let mut c = moment[m];
                if c != 0 {
                    c = c.checked_mul(b.denominator.checked_pow(self.degree as u32 - term.index_degree[k])?)?;
                    let mut rest = k;
                    for v in (0..s).rev() {
                        let kv = rest % term.dims[v];
                        rest /= term.dims[v];
                        c = c.checked_mul(term.binomials[v][kv])?;
                    }
                    if negative {
                        c = -c;
                    }
                }
                tensor.push(c);
            }
            // Shift every axis: (q zeta_v + X_v)^k = sum_l C(k, l) X_v^(k-l) q^l zeta_v^l.
            for v in 0..s {
                let x = dot(&term.rows[v], &b.numerators)?;
                let p = term.powers[v] as usize;
                if p == 0 {
                    continue;
                }
                let inner: usize = term.dims[v + 1..].iter().product();
                next.clear();
                next.resize(size, 0);
                for (flat, &c) in tensor.iter().enumerate() {
                    if c == 0 {
                        continue;
                    }
                    let k = (flat / inner) % (p + 1);
                    let lowest = flat - k * inner;
                    // C(k, l) X^(k-l) q^l for l = k down to 0.
                    let mut xpow: i128 = 1;
                    for l in (0..=k).rev() {
                        let coefficient =
                            binomial(k, l)?.checked_mul(xpow)?.checked_mul(b.denominator.checked_pow(l as u32)?)?;
                        let slot = &mut next[lowest + l * inner];
                        *slot = mul_add(*slot, c, coefficient)?;
                        xpow = xpow.checked_mul(x)?;
                    }
                }
                std::mem::swap(&mut tensor, &mut next);
            }
            let mut poly = vec![0i128; basis.len()];
            for (l, &t) in tensor.iter().enumerate() {
                if t == 0 {
                    continue;
                }
                for (acc, n) in poly.iter_mut().zip(&term.images[l]) {
                    if *n != 0 {
                        *acc = mul_add(*acc, t, *n)?;
                    }
                }
            }
            // c = scale coef / (q D)^degree
            let qd = b.denominator.checked_mul(term.denominator)?.checked_pow(self.degree as u32)?;
            let c = &(scale * &term.coef) / &ratio(qd, 1);
            per_term.push((c, poly));
        }
        // sum_i c_i I_i over one common denominator.
        let mut denominator: i128 = 1;
        for (c, _) in &per_term {
            denominator = lcm(denominator, *small(c)?.denom())?;
        }
        for (c, poly) in &per_term {
            let r = small(c)?;
            let factor = r.numer().checked_mul(denominator / r.denom())?;
            for (acc, n) in total.iter_mut().zip(poly) {
                if *n != 0 {
                    *acc = mul_add(*acc, factor, *n)?;
                }
            }
        }
        let coeffs = total.into_iter().map(|n| if n == 0 { Q::zero() } else { ratio(n, denominator) }).collect();
        Some(Poly { basis, coeffs })
    }
}

impl TermTable {
    fn new(term: &ConeTerm, shifts: &[Vec<i128>], weights: &[i128], s: usize, degree: usize) -> Option<TermTable> {
        if term.powers.iter().sum::<u32>() as usize != degree {
            return None;
        }
        let flat: QVec = term.inv.iter().flatten().cloned().collect();
        let scaled = Scaled::from_q(&flat)?;
        let rows: Vec<Vec<i128>> = scaled.numerators.chunks(s).map(|r| r.to_vec()).collect();
        let dims: Vec<usize> = term.powers.iter().map(|&p| p as usize + 1).collect();
        let size: usize = dims.iter().product();
        let indices: Vec<Vec<u32>> = (0..size).map(|f| unflatten(f, &dims)).collect();
        // Shifts with their dots, sorted by the first.
        let mut rows_of_shifts: Vec<(Vec<i64>, i128)> = Vec::with_capacity(shifts.len());
        for (sh, &w) in shifts.iter().zip(weights) {
            let sd =
                rows.iter().map(|r| dot(r, sh).and_then(|x| i64::try_from(x).ok())).collect::<Option<Vec<i64>>>()?;
            rows_of_shifts.push((sd, w));
        }
        rows_of_shifts.sort();
        let mut shift_dots = Vec::with_capacity(shifts.len() * s);
        let mut moments = Vec::with_capacity(shifts.len() * size);
        for (sd, w) in &rows_of_shifts {
            shift_dots.extend_from_slice(sd);
            for m in &indices {
                let mut c = *w;
                for (v, &mv) in m.iter().enumerate() {
                    c = c.checked_mul((sd[v] as i128).checked_pow(mv)?)?;
                }
                moments.push(c);
            }
        }
        let binomials: Vec<Vec<i128>> = term
            .powers
            .iter()
            .map(|&p| (0..=p as usize).map(|k| binomial(p as usize, k)).collect())
            .collect::<Option<_>>()?;
        let row_forms: Vec<Vec<Q>> = rows.iter().map(|r| r.iter().map(|&x| ratio(x, 1)).collect()).collect();
        let mut images = Vec::with_capacity(size);
        let mut complement = Vec::with_capacity(size);
        let mut index_degree = Vec::with_capacity(size);
        for k in &indices {
            let mut p = Poly::constant(s, degree, Q::one());
            for (v, &kv) in k.iter().enumerate() {
                for _ in 0..kv {
                    p = p.mul_affine(&row_forms[v], &Q::zero());
                }
            }
            images.push(p.coeffs.iter().map(integer).collect::<Option<Vec<i128>>>()?);
            let m: Vec<u32> = k.iter().zip(&term.powers).map(|(kv, pv)| pv - kv).collect();
            complement.push((flatten(&m, &dims), m.iter().sum::<u32>() % 2 == 1));
            index_degree.push(k.iter().sum());
        }
        Some(TermTable {
            rows,
            denominator: scaled.denominator,
            powers: term.powers.clone(),
            dims,
            shift_dots,
            moments,
            binomials,
            images,
            complement,
            index_degree,
            coef: term.coef.clone(),
        })
    }
}

/// Row-major tensor index -> multi-index (last axis fastest).
fn unflatten(mut flat: usize, dims: &[usize]) -> Vec<u32> {
    let mut k = vec![0u32; dims.len()];
    for v in (0..dims.len()).rev() {
        k[v] = (flat % dims[v]) as u32;
        flat /= dims[v];
    }
    k
}

fn flatten(k: &[u32], dims: &[usize]) -> usize {
    k.iter().zip(dims).fold(0, |acc, (&kv, &d)| acc * d + kv as usize)
}

/// The first index in 0..n where `pred` is false (pred holds on a prefix).
fn partition_point(n: usize, pred: impl Fn(usize) -> bool) -> usize {
    let (mut lo, mut hi) = (0, n);
    while lo < hi {
        let mid = (lo + hi) / 2;
        if pred(mid) {
            lo = mid + 1;
        } else {
            hi = mid;
        }
    }
    lo
}

fn binomial(n: usize, k: usize) -> Option<i128> {
    if k > n {
        return Some(0);
    }
    let mut acc: i128 = 1;
    for i in 0..k {
        acc = acc.checked_mul((n - i) as i128)? / (i as i128 + 1);
    }
    Some(acc)
}

fn dot(a: &[i128], b: &[i128]) -> Option<i128> {
    a.iter().zip(b).try_fold(0i128, |acc, (x, y)| mul_add(acc, *x, *y))
}

#[cfg(test)]
mod tests {
    use crate::derive::Derivation;
    use crate::math::linalg::add_i;
    use crate::spec::{catalog, random};

    /// The integer path gives exactly the rational path's polynomials.
    fn check(d: &Derivation, max_refs: usize, max_offsets: usize) -> usize {
        assert!(d.pp.tables.is_some(), "{}: tables fit i128", d.filter.name);
        let mut checked = 0;
        for r in d.references.iter().take(max_refs) {
            let c = &d.arrangement.cells[r.cell];
            let origin = d.cube_origin(&r.corner);
            for k in r.stencil.iter().take(max_offsets) {
                let j = add_i(&r.corner, k);
                let fast = d.pp.local_piece(&origin, &c.interior, &j);
                let exact = d.pp.local_piece_rational(&origin, &c.interior, &j);
                assert_eq!(fast, exact, "{} cell {} offset {k:?}", d.filter.name, r.cell);
                checked += 1;
            }
        }
        checked
    }

    #[test]
    fn integer_pieces_equal_rational_pieces_on_the_catalog() {
        for f in catalog::all().unwrap() {
            let d = Derivation::new(&f).unwrap();
            assert!(check(&d, usize::MAX, usize::MAX) > 0);
        }
    }

    #[test]
    fn integer_pieces_equal_rational_pieces_on_random_specs() {
        let mut checked = 0;
        for f in random::benchmark_specs(11, 30) {
            let Ok(d) = Derivation::new(&f) else { continue };
            checked += check(&d, 2, 24);
        }
        assert!(checked > 300, "{checked} pieces compared");
    }
}
