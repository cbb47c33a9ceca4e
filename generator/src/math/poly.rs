//! Dense multivariate polynomials of bounded total degree with exact
//! rational coefficients.

use crate::math::exact::Q;
use std::collections::HashMap;
use std::sync::{Arc, Mutex, OnceLock};

/// The monomials x^e with |e| <= degree in `nvars` variables, graded
/// (degree 0 first) and lexicographically descending within a degree.
#[derive(Debug)]
pub struct Monomials {
    /// Number of variables.
    pub nvars: usize,
    /// Largest total degree.
    pub degree: usize,
    /// Exponent vectors, graded and lexicographically descending within a degree.
    pub exps: Vec<Vec<u32>>,
    index: HashMap<Vec<u32>, usize>,
    /// times_var[i][v]: index of exps[i] + e_v, or usize::MAX past the degree.
    times_var: Vec<Vec<usize>>,
}

impl Monomials {
    /// Shared table for (nvars, degree).
    pub fn get(nvars: usize, degree: usize) -> Arc<Monomials> {
        type Cache = Mutex<HashMap<(usize, usize), Arc<Monomials>>>;
        static CACHE: OnceLock<Cache> = OnceLock::new();
        let cache = CACHE.get_or_init(|| Mutex::new(HashMap::new()));
        let mut guard = cache.lock().unwrap_or_else(|e| e.into_inner());
        guard.entry((nvars, degree)).or_insert_with(|| Arc::new(Monomials::build(nvars, degree))).clone()
    }

    fn build(nvars: usize, degree: usize) -> Monomials {
        let mut exps = Vec::new();
        for d in 0..=degree {
            let mut level = Vec::new();
            compositions(nvars, d as u32, &mut vec![], &mut level);
            level.sort_by(|a, b| b.cmp(a));
            exps.extend(level);
        }
        let index: HashMap<Vec<u32>, usize> = exps.iter().enumerate().map(|(i, e)| (e.clone(), i)).collect();
        let times_var = exps
            .iter()
            .map(|e| {
                (0..nvars)
                    .map(|v| {
                        let mut f = e.clone();
                        f[v] += 1;
                        index.get(&f).copied().unwrap_or(usize::MAX)
                    })
                    .collect()
            })
            .collect();
        Monomials { nvars, degree, exps, index, times_var }
    }

    /// Number of monomials.
    pub fn len(&self) -> usize {
        self.exps.len()
    }

    /// Are there no monomials?
    pub fn is_empty(&self) -> bool {
        self.exps.is_empty()
    }

    /// Position of the monomial with exponents `e`; None if it is not in the basis.
    pub fn index_of(&self, e: &[u32]) -> Option<usize> {
        self.index.get(e).copied()
    }
}

fn compositions(n: usize, total: u32, cur: &mut Vec<u32>, out: &mut Vec<Vec<u32>>) {
    if cur.len() + 1 == n {
        cur.push(total);
        out.push(cur.clone());
        cur.pop();
        return;
    }
    if n == 0 {
        return;
    }
    for k in 0..=total {
        cur.push(k);
        compositions(n, total - k, cur, out);
        cur.pop();
    }
}

/// A polynomial sum_e c_e x^e with |e| <= basis.degree.
#[derive(Clone, Debug)]
pub struct Poly {
    /// The monomials the coefficients refer to.
    pub basis: Arc<Monomials>,
    /// Coefficient of each monomial, in `basis.exps` order.
    pub coeffs: Vec<Q>,
}

impl PartialEq for Poly {
    fn eq(&self, other: &Poly) -> bool {
        self.basis.nvars == other.basis.nvars && {
            let n = self.coeffs.len().max(other.coeffs.len());
            let big = if self.coeffs.len() >= other.coeffs.len() { self } else { other };
            let small = if self.coeffs.len() >= other.coeffs.len() { other } else { self };
            (0..n).all(|i| {
                let a = &big.coeffs[i];
                match small.basis.index_of(&big.basis.exps[i]) {
                    Some(j) => *a == small.coeffs[j],
                    None => a.is_zero(),
                }
            })
        }
    }
}

impl Poly {
    /// The zero polynomial on the basis of all monomials up to `degree`.
    pub fn zero(nvars: usize, degree: usize) -> Poly {
        let basis = Monomials::get(nvars, degree);
        let coeffs = vec![Q::zero(); basis.len()];
        Poly { basis, coeffs }
    }

    /// The constant c on that basis.
    pub fn constant(nvars: usize, degree: usize, c: Q) -> Poly {
        let mut p = Poly::zero(nvars, degree);
        p.coeffs[0] = c;
        p
    }

    /// Number of variables.
    pub fn nvars(&self) -> usize {
        self.basis.nvars
    }

    /// Are all coefficients 0?
    pub fn is_zero(&self) -> bool {
        self.coeffs.iter().all(|c| c.is_zero())
    }

    /// The actual total degree (-1 for the zero polynomial).
    pub fn actual_degree(&self) -> i64 {
        self.coeffs
            .iter()
            .zip(&self.basis.exps)
            .filter(|(c, _)| !c.is_zero())
            .map(|(_, e)| e.iter().sum::<u32>() as i64)
            .max()
            .unwrap_or(-1)
    }

    /// self * (a . x + b). Panics if the product exceeds the basis degree
    /// (a programming error: callers size the basis).
    pub fn mul_affine(&self, a: &[Q], b: &Q) -> Poly {
        let mut out = Poly { basis: self.basis.clone(), coeffs: vec![Q::zero(); self.coeffs.len()] };
        for (i, c) in self.coeffs.iter().enumerate() {
            if c.is_zero() {
                continue;
            }
            if !b.is_zero() {
                out.coeffs[i] += &(c * b);
            }
            for (v, av) in a.iter().enumerate() {
                if av.is_zero() {
                    continue;
                }
                let j = self.basis.times_var[i][v];
                assert!(j != usize::MAX, "polynomial degree overflow");
                out.coeffs[j] += &(c * av);
            }
        }
        out
    }

    /// self += other (same basis).
    pub fn add_assign(&mut self, other: &Poly) {
        debug_assert!(Arc::ptr_eq(&self.basis, &other.basis));
        for (a, b) in self.coeffs.iter_mut().zip(&other.coeffs) {
            if !b.is_zero() {
                *a += b;
            }
        }
    }

    /// self += s * other (same basis).
    pub fn add_scaled(&mut self, other: &Poly, s: &Q) {
        debug_assert!(Arc::ptr_eq(&self.basis, &other.basis));
        for (a, b) in self.coeffs.iter_mut().zip(&other.coeffs) {
            if !b.is_zero() {
                *a += &(b * s);
            }
        }
    }

    /// s * self.
    pub fn scale(&self, s: &Q) -> Poly {
        Poly { basis: self.basis.clone(), coeffs: self.coeffs.iter().map(|c| c * s).collect() }
    }

    /// The exact value at x.
    pub fn eval(&self, x: &[Q]) -> Q {
        // Powers per variable, then sum.
        let d = self.basis.degree;
        let pows: Vec<Vec<Q>> = x
            .iter()
            .map(|xi| {
                let mut p = vec![Q::one()];
                for k in 1..=d {
                    let next = &p[k - 1] * xi;
                    p.push(next);
                }
                p
            })
            .collect();
        let mut acc = Q::zero();
        for (c, e) in self.coeffs.iter().zip(&self.basis.exps) {
            if c.is_zero() {
                continue;
            }
            let mut term = c.clone();
            for (v, &k) in e.iter().enumerate() {
                if k > 0 {
                    term *= &pows[v][k as usize];
                }
            }
            acc += &term;
        }
        acc
    }

    /// Partial derivative along variable v (same basis).
    pub fn derivative(&self, v: usize) -> Poly {
        let mut out = Poly::zero(self.nvars(), self.basis.degree);
        for (i, e) in self.basis.exps.iter().enumerate() {
            if e[v] == 0 || self.coeffs[i].is_zero() {
                continue;
            }
            let mut f = e.clone();
            f[v] -= 1;
            let j = self
                .basis
                .index_of(&f)
                .expect("the basis holds every monomial up to its degree, and f is e lowered by one");
            out.coeffs[j] += &(&self.coeffs[i] * &Q::int(e[v] as i64));
        }
        out
    }

    /// p(A x + b): substitutes affine forms (rows of A with b) for the variables.
    pub fn compose_affine(&self, a: &[Vec<Q>], b: &[Q]) -> Poly {
        let n = a[0].len();
        let forms: Vec<(Vec<Q>, Q)> = a.iter().cloned().zip(b.iter().cloned()).collect();
        let mut out = Poly::zero(n, self.basis.degree);
        for (c, e) in self.coeffs.iter().zip(&self.basis.exps) {
            if c.is_zero() {
                continue;
            }
            let mut term = Poly::constant(n, self.basis.degree, c.clone());
            for (v, &k) in e.iter().enumerate() {
                for _ in 0..k {
                    term = term.mul_affine(&forms[v].0, &forms[v].1);
                }
            }
            out.add_assign(&term);
        }
        out
    }
}

/// A dense tensor sum_e c_e prod_v t_v^{e_v} with e_v < `dims[v]` (row-major,
/// last variable fastest), turned into a polynomial of u with t = A u + b by
/// nested Horner steps; cheap when A is sparse.
pub fn tensor_to_poly(tensor: &[Q], dims: &[usize], a: &[Vec<Q>], b: &[Q], nvars: usize, degree: usize) -> Poly {
    fn rec(t: &[Q], dims: &[usize], a: &[Vec<Q>], b: &[Q], nvars: usize, degree: usize) -> Poly {
        let (k, rest) = (dims[0], &dims[1..]);
        let stride: usize = rest.iter().product();
        let slice = |i: usize| &t[i * stride..(i + 1) * stride];
        let inner = |i: usize| -> Poly {
            if rest.is_empty() {
                Poly::constant(nvars, degree, t[i].clone())
            } else {
                rec(slice(i), rest, &a[1..], &b[1..], nvars, degree)
            }
        };
        let mut acc = inner(k - 1);
        for i in (0..k - 1).rev() {
            acc = acc.mul_affine(&a[0], &b[0]);
            let q = inner(i);
            acc.add_assign(&q);
        }
        acc
    }
    if tensor.iter().all(|c| c.is_zero()) {
        return Poly::zero(nvars, degree);
    }
    rec(tensor, dims, a, b, nvars, degree)
}

/// Value and gradient of sum c_e u^e.
pub fn eval_poly_f64(exps: &[Vec<u32>], coeffs: &[f64], u: &[f64]) -> (f64, Vec<f64>) {
    let s = u.len();
    let mut v = 0.0;
    let mut g = vec![0.0; s];
    for (e, &c) in exps.iter().zip(coeffs) {
        if c == 0.0 {
            continue;
        }
        let mut m = c;
        for i in 0..s {
            m *= u[i].powi(e[i] as i32);
        }
        v += m;
        for d in 0..s {
            if e[d] == 0 {
                continue;
            }
            let mut md = c * e[d] as f64;
            for i in 0..s {
                let k = if i == d { e[i] - 1 } else { e[i] };
                md *= u[i].powi(k as i32);
            }
            g[d] += md;
        }
    }
    (v, g)
}

/// Value, gradient and Hessian (row-major s x s) of sum_e c_e u^e in f64.
pub fn eval_poly_f64_hessian(exps: &[Vec<u32>], coeffs: &[f64], u: &[f64]) -> (f64, Vec<f64>, Vec<f64>) {
    let s = u.len();
    let (v, g) = eval_poly_f64(exps, coeffs, u);
    let mut h = vec![0.0; s * s];
    for (e, &c) in exps.iter().zip(coeffs) {
        if c == 0.0 {
            continue;
        }
        for a in 0..s {
            for b in a..s {
                let mut k: Vec<i64> = e.iter().map(|&x| i64::from(x)).collect();
                let mut m = c * k[a] as f64;
                k[a] -= 1;
                m *= k[b] as f64;
                k[b] -= 1;
                if m == 0.0 {
                    continue;
                }
                for i in 0..s {
                    m *= u[i].powi(k[i] as i32);
                }
                h[a * s + b] += m;
                if a != b {
                    h[b * s + a] += m;
                }
            }
        }
    }
    (v, g, h)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn f64_hessian_matches_differences_of_the_gradient() {
        let exps: Vec<Vec<u32>> = vec![vec![2, 1, 0], vec![0, 3, 1], vec![1, 1, 1], vec![0, 0, 2], vec![1, 0, 0]];
        let coeffs = [0.5, -1.25, 2.0, 0.75, 3.0];
        let u = [0.3, -0.6, 0.45];
        let (_, _, h) = eval_poly_f64_hessian(&exps, &coeffs, &u);
        let eps = 1e-5;
        for a in 0..3 {
            for b in 0..3 {
                let (mut up, mut dn) = (u, u);
                up[b] += eps;
                dn[b] -= eps;
                let fd =
                    (eval_poly_f64(&exps, &coeffs, &up).1[a] - eval_poly_f64(&exps, &coeffs, &dn).1[a]) / (2.0 * eps);
                assert!((h[a * 3 + b] - fd).abs() < 1e-7, "d2/du{a}du{b}: {} vs {fd}", h[a * 3 + b]);
            }
        }
    }

    #[test]
    fn basis_sizes() {
        assert_eq!(Monomials::get(3, 9).len(), 220);
        assert_eq!(Monomials::get(2, 2).len(), 6);
        assert_eq!(Monomials::get(3, 0).exps, vec![vec![0, 0, 0]]);
    }

    #[test]
    fn affine_products_and_composition() {
        // (x + 2y - 1)^2 at (3, 1/2)
        let q = |n| Q::int(n);
        let mut p = Poly::constant(2, 2, Q::one());
        p = p.mul_affine(&[q(1), q(2)], &q(-1));
        p = p.mul_affine(&[q(1), q(2)], &q(-1));
        assert_eq!(p.eval(&[q(3), Q::frac(1, 2)]), q(9));
        // derivative wrt x: 2(x + 2y - 1) = 6 at that point
        assert_eq!(p.derivative(0).eval(&[q(3), Q::frac(1, 2)]), q(6));
        // compose with x = u + v, y = u - v
        let c = p.compose_affine(&[vec![q(1), q(1)], vec![q(1), q(-1)]], &[q(0), q(0)]);
        // at u = 7/4, v = 5/4: x = 3, y = 1/2
        assert_eq!(c.eval(&[Q::frac(7, 4), Q::frac(5, 4)]), q(9));
    }

    #[test]
    fn tensor_horner() {
        // t0^1 * t1^2 with t0 = 2u, t1 = v + 1, tensor dims [2,3]
        let q = |n| Q::int(n);
        let mut t = vec![Q::zero(); 6];
        t[3 + 2] = Q::one();
        let p = tensor_to_poly(&t, &[2, 3], &[vec![q(2), q(0)], vec![q(0), q(1)]], &[q(0), q(1)], 2, 3);
        assert_eq!(p.eval(&[q(3), q(2)]), q(6 * 9));
    }
}
