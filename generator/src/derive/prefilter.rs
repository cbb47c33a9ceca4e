//! The quasi-interpolation prefilter (docs/BOX_SPLINES.md §3 step 11).
//!
//! With phi the centred box spline on L, the spline s = sum_j c_j phi(. - j)
//! with coefficients c = q * f (discrete convolution on L) reproduces every
//! polynomial of degree below rho when
//!
//! ```text
//!   Q(w) phihat(w) = 1 + O(|w|^rho),   phihat(w) = prod_xi sinc(xi.w/2),
//!   Q(w) = sum_j q_j cos(j.w).
//! ```
//!
//! Both factors are even, so only the Taylor coefficients of even total order
//! below rho give conditions. q is sought P-invariant: one unknown per shell
//! (orbit of lattice points under P), shells taken in a fixed order (squared
//! norm, then the canonical representative). Shells are added one at a time
//! until the exact linear system is consistent; free unknowns (shells whose
//! column depends on earlier ones) are set to zero, so the result is
//! deterministic. Everything is exact rational arithmetic.

use crate::derive::symmetry::SignedPerm;
use crate::error::{Error, Result};
use crate::math::exact::{factorial, Q};
use crate::math::linalg::{dot_i, mat_vec_i, IVec};
use crate::spec::lattice::Lattice;
use crate::spec::Filter;
use std::collections::{BTreeMap, BTreeSet};

/// The default limit on the number of shells [`derive_prefilter`] tries.
pub const MAX_SHELLS: usize = 12;

/// The quasi-interpolation prefilter: weights q_j on lattice points j.
#[derive(Clone, Debug, PartialEq, Eq, serde::Serialize)]
pub struct Prefilter {
    /// The non-zero weights, sorted by (|j|^2, j).
    pub taps: Vec<(IVec, Q)>,
    /// The number of shells (orbits, origin included) the system needed.
    pub shells: usize,
}

impl Prefilter {
    /// Q(w) = sum_j q_j cos(j.w) in f64 (for reports and numeric checks).
    pub fn symbol(&self, w: &[f64]) -> f64 {
        self.taps.iter().map(|(j, q)| q.to_f64() * j.iter().zip(w).map(|(a, b)| *a as f64 * b).sum::<f64>().cos()).sum()
    }

    /// The weight at lattice point j (zero off the taps).
    pub fn weight(&self, j: &[i64]) -> Q {
        self.taps.iter().find(|(p, _)| p.as_slice() == j).map(|(_, q)| q.clone()).unwrap_or_default()
    }
}

/// Smallest P-invariant q on L (fewest shells = orbits of lattice points under
/// the group, ordered by squared norm then lexicographically by a canonical
/// representative, the lexicographically greatest point of the orbit) with
///   Q(w) * prod_xi sinc(xi.w/2) = 1 + O(|w|^rho),  Q(w) = sum_j q_j cos(j.w),
/// i.e. the Taylor coefficients of every even total order < rho match.
///
/// Orbits are closed under the group and under x -> -x (Q is a cosine sum,
/// so q must be even; every point group of a box spline contains -I anyway).
/// rho <= 2 gives the delta at the origin. Errors with
/// [`Error::Prefilter`] when [`shell_limit`] shells do not suffice.
///
/// # Errors
///
/// [`Error::Prefilter`] when [`shell_limit`] shells do not suffice.
pub fn derive_prefilter(filter: &Filter, group: &[SignedPerm], rho: usize) -> Result<Prefilter> {
    derive_prefilter_with_limit(filter, group, rho, shell_limit(filter.dim(), rho))
}

/// How many shells [`derive_prefilter`] tries: [`MAX_SHELLS`] beyond the
/// number of conditions (even-order Taylor coefficients below rho), so a
/// filter with little symmetry, whose shells are single pairs {j, -j}, still
/// gets one unknown per condition.
pub fn shell_limit(dim: usize, rho: usize) -> usize {
    MAX_SHELLS + even_monomials(dim, rho.max(1) - 1).len()
}

/// [`derive_prefilter`] with an explicit shell limit.
///
/// # Errors
///
/// [`Error::Prefilter`] when `max_shells` shells do not suffice.
pub fn derive_prefilter_with_limit(
    filter: &Filter,
    group: &[SignedPerm],
    rho: usize,
    max_shells: usize,
) -> Result<Prefilter> {
    let dim = filter.dim();
    // Conditions: Taylor coefficients of even total degree <= max_deg (odd
    // ones vanish identically on both sides).
    let max_deg = rho.max(1) - 1;
    let phihat = phihat_taylor(&filter.directions, dim, max_deg);
    let shells = shells(&filter.lattice, group, max_shells);
    let monomials = even_monomials(dim, max_deg);
    let rhs: Vec<Q> = monomials.iter().map(|m| if m.iter().all(|&e| e == 0) { Q::one() } else { Q::zero() }).collect();
    // Shells are added one at a time; an echelon basis of the columns so far
    // tells at once whether the right-hand side is in their span (the
    // fewest shells that suffice), and only then is the system solved.
    let mut columns: Vec<Vec<Q>> = Vec::new();
    let mut span = Span::default();
    for (k, shell) in shells.iter().enumerate() {
        let mut cos_sum = Poly::new();
        for j in shell {
            add_into(&mut cos_sum, &cos_taylor(j, max_deg));
        }
        let col = mul_trunc(&cos_sum, &phihat, max_deg);
        let column: Vec<Q> = monomials.iter().map(|m| col.get(m).cloned().unwrap_or_default()).collect();
        span.add(column.clone());
        columns.push(column);
        if !span.contains(&rhs) {
            continue;
        }
        let x = solve_prefix(&columns, &rhs).expect("the right-hand side is in the span of the columns");
        let mut taps: Vec<(IVec, Q)> = Vec::new();
        for (shell, q) in shells[..=k].iter().zip(&x) {
            if !q.is_zero() {
                taps.extend(shell.iter().map(|j| (j.clone(), q.clone())));
            }
        }
        taps.sort_by_key(|(j, _)| (norm2(j), j.clone()));
        return Ok(Prefilter { taps, shells: k + 1 });
    }
    Err(Error::Prefilter { shells: max_shells })
}

/// An echelon basis of the columns added so far: (pivot row, column with a 1 there).
#[derive(Default)]
struct Span {
    basis: Vec<(usize, Vec<Q>)>,
}

impl Span {
    fn reduce(&self, v: &[Q]) -> Vec<Q> {
        let mut r = v.to_vec();
        for (pivot, b) in &self.basis {
            if r[*pivot].is_zero() {
                continue;
            }
            let f = r[*pivot].clone();
            for (x, y) in r.iter_mut().zip(b) {
                if !y.is_zero() {
                    *x -= &(&f * y);
                }
            }
        }
        r
    }

    fn add(&mut self, v: Vec<Q>) {
        let r = self.reduce(&v);
        if let Some(pivot) = r.iter().position(|x| !x.is_zero()) {
            let inv = r[pivot].recip();
            let b: Vec<Q> = r.iter().map(|x| x * &inv).collect();
            // Keep the basis reduced at the new pivot so later reductions stay one pass.
            for (_, other) in &mut self.basis {
                if !other[pivot].is_zero() {
                    let f = other[pivot].clone();
                    for (x, y) in other.iter_mut().zip(&b) {
                        if !y.is_zero() {
                            *x -= &(&f * y);
                        }
                    }
                }
            }
            self.basis.push((pivot, b));
        }
    }

    fn contains(&self, v: &[Q]) -> bool {
        self.reduce(v).iter().all(|x| x.is_zero())
    }
}

/// Monomials of even total degree <= max_deg, in the order of [`monomials`].
fn even_monomials(dim: usize, max_deg: usize) -> Vec<Vec<u32>> {
    monomials(dim, max_deg).into_iter().filter(|m| degree(m).is_multiple_of(2)).collect()
}

// ---------------------------------------------------------------------------
// Shells.

fn norm2(j: &[i64]) -> i64 {
    dot_i(j, j)
}

/// The orbit of p under the group generated by `gens` (closure by BFS).
fn orbit(p: &IVec, gens: &[SignedPerm]) -> BTreeSet<IVec> {
    let mut seen: BTreeSet<IVec> = BTreeSet::new();
    seen.insert(p.clone());
    let mut todo = vec![p.clone()];
    while let Some(x) = todo.pop() {
        for g in gens {
            let y = mat_vec_i(g, &x);
            if seen.insert(y.clone()) {
                todo.push(y);
            }
        }
    }
    seen
}

/// All integer points of the box [-r, r]^dim.
fn box_points(dim: usize, r: i64) -> Vec<IVec> {
    let mut out = vec![vec![]];
    for _ in 0..dim {
        out = out
            .into_iter()
            .flat_map(|p: IVec| {
                (-r..=r).map(move |k| {
                    let mut q = p.clone();
                    q.push(k);
                    q
                })
            })
            .collect();
    }
    out
}

/// The first `count` shells of L under the group (and -I), in the order
/// (squared norm, lexicographically greatest point of the orbit). Each shell
/// is sorted. The first shell is the origin.
fn shells(lattice: &Lattice, group: &[SignedPerm], count: usize) -> Vec<Vec<IVec>> {
    let dim = lattice.dim();
    let mut gens: Vec<SignedPerm> = group.to_vec();
    gens.push((0..dim).map(|i| (0..dim).map(|k| if i == k { -1 } else { 0 }).collect()).collect());
    let mut r: i64 = 2;
    loop {
        // Every lattice point with |j|^2 <= r^2 lies in the box; orbits keep
        // the norm, so the shells found form an exact prefix of the order.
        let mut found: BTreeMap<(i64, IVec), Vec<IVec>> = BTreeMap::new();
        let mut assigned: BTreeSet<IVec> = BTreeSet::new();
        for p in box_points(dim, r) {
            if norm2(&p) > r * r || assigned.contains(&p) || !lattice.contains(&p) {
                continue;
            }
            let orb = orbit(&p, &gens);
            for x in &orb {
                assert!(lattice.contains(x), "a group element maps {p:?} to {x:?}, off the lattice");
            }
            assigned.extend(orb.iter().cloned());
            let rep = orb.iter().next_back().expect("an orbit contains its own point p").clone();
            found.insert((norm2(&p), rep), orb.into_iter().collect());
        }
        if found.len() >= count {
            return found.into_values().take(count).collect();
        }
        r *= 2;
    }
}

// ---------------------------------------------------------------------------
// Truncated multivariate Taylor polynomials with exact coefficients.

/// Exponent vector -> coefficient (no zero coefficients stored).
type Poly = BTreeMap<Vec<u32>, Q>;

fn degree(m: &[u32]) -> usize {
    m.iter().map(|&e| e as usize).sum()
}

/// All exponent vectors of total degree <= max_deg, graded.
fn monomials(dim: usize, max_deg: usize) -> Vec<Vec<u32>> {
    fn rec(dim: usize, left: u32, cur: &mut Vec<u32>, out: &mut Vec<Vec<u32>>) {
        if cur.len() == dim {
            out.push(cur.clone());
            return;
        }
        for e in 0..=left {
            cur.push(e);
            rec(dim, left - e, cur, out);
            cur.pop();
        }
    }
    let mut out = Vec::new();
    rec(dim, max_deg as u32, &mut Vec::new(), &mut out);
    out.sort_by_key(|m| (degree(m), std::cmp::Reverse(m.clone())));
    out
}

fn add_into(acc: &mut Poly, p: &Poly) {
    for (m, c) in p {
        let e = acc.entry(m.clone()).or_default();
        *e += c;
        if e.is_zero() {
            acc.remove(m);
        }
    }
}

fn mul_trunc(a: &Poly, b: &Poly, max_deg: usize) -> Poly {
    let mut out = Poly::new();
    for (ma, ca) in a {
        let da = degree(ma);
        for (mb, cb) in b {
            if da + degree(mb) > max_deg {
                continue;
            }
            let m: Vec<u32> = ma.iter().zip(mb).map(|(x, y)| x + y).collect();
            let e = out.entry(m).or_default();
            *e += &(ca * cb);
        }
    }
    out.retain(|_, c| !c.is_zero());
    out
}

fn scale(p: &Poly, s: &Q) -> Poly {
    p.iter().map(|(m, c)| (m.clone(), c * s)).filter(|(_, c)| !c.is_zero()).collect()
}

/// The linear form a.w.
fn linear(a: &[Q]) -> Poly {
    let dim = a.len();
    let mut p = Poly::new();
    for (i, c) in a.iter().enumerate() {
        if !c.is_zero() {
            let mut m = vec![0; dim];
            m[i] = 1;
            p.insert(m, c.clone());
        }
    }
    p
}

fn constant(dim: usize, c: Q) -> Poly {
    let mut p = Poly::new();
    if !c.is_zero() {
        p.insert(vec![0; dim], c);
    }
    p
}

/// sum_n coef(n) (a.w)^(2n), truncated to total degree <= max_deg.
fn even_series(a: &[Q], max_deg: usize, coef: impl Fn(u32) -> Q) -> Poly {
    let dim = a.len();
    let lin = linear(a);
    let sq = mul_trunc(&lin, &lin, max_deg);
    let mut power = constant(dim, Q::one()); // (a.w)^(2n)
    let mut out = Poly::new();
    let mut n = 0u32;
    while 2 * n as usize <= max_deg && !power.is_empty() {
        add_into(&mut out, &scale(&power, &coef(n)));
        power = mul_trunc(&power, &sq, max_deg);
        n += 1;
    }
    out
}

fn sign(n: u32) -> Q {
    if n.is_multiple_of(2) {
        Q::one()
    } else {
        -Q::one()
    }
}

/// cos(j.w) = sum (-1)^n (j.w)^(2n) / (2n)!.
fn cos_taylor(j: &[i64], max_deg: usize) -> Poly {
    let a: Vec<Q> = j.iter().map(|&x| Q::int(x)).collect();
    even_series(&a, max_deg, |n| sign(n) / factorial(2 * n))
}

/// prod_xi sinc(xi.w/2), sinc(u) = sum (-1)^n u^(2n) / (2n+1)!.
fn phihat_taylor(directions: &[IVec], dim: usize, max_deg: usize) -> Poly {
    let mut acc = constant(dim, Q::one());
    for xi in directions {
        let half: Vec<Q> = xi.iter().map(|&x| Q::frac(x, 2)).collect();
        let s = even_series(&half, max_deg, |n| sign(n) / factorial(2 * n + 1));
        acc = mul_trunc(&acc, &s, max_deg);
    }
    acc
}

// ---------------------------------------------------------------------------
// Exact linear solve.

/// Solves sum_k x_k columns[k] = rhs exactly. None if inconsistent; free
/// unknowns (columns in the span of earlier ones) are zero.
fn solve_prefix(columns: &[Vec<Q>], rhs: &[Q]) -> Option<Vec<Q>> {
    let n = columns.len();
    let rows = rhs.len();
    // Augmented row-major matrix [A | b].
    let mut a: Vec<Vec<Q>> = (0..rows)
        .map(|r| {
            let mut row: Vec<Q> = columns.iter().map(|c| c[r].clone()).collect();
            row.push(rhs[r].clone());
            row
        })
        .collect();
    let mut pivots: Vec<usize> = Vec::new();
    let mut r = 0;
    for c in 0..=n {
        if r == rows {
            break;
        }
        let Some(p) = (r..rows).find(|&i| !a[i][c].is_zero()) else {
            continue;
        };
        if c == n {
            return None; // a pivot in the right-hand side: inconsistent
        }
        a.swap(p, r);
        let inv = a[r][c].recip();
        for x in a[r].iter_mut() {
            *x = &*x * &inv;
        }
        let pivot_row = a[r].clone();
        for (i, row) in a.iter_mut().enumerate() {
            if i != r && !row[c].is_zero() {
                let f = row[c].clone();
                for (x, p) in row.iter_mut().zip(&pivot_row).skip(c) {
                    if !p.is_zero() {
                        *x -= &(&f * p);
                    }
                }
            }
        }
        pivots.push(c);
        r += 1;
    }
    let mut x = vec![Q::zero(); n];
    for (row, &c) in pivots.iter().enumerate() {
        x[c] = a[row][n].clone();
    }
    Some(x)
}

#[cfg(test)]
mod tests;
