//! Exact polynomial pieces (PP-form) of phi, after Horacsek & Alim: the
//! truncated power T_Xi is split by partial fractions of its Laplace
//! transform prod 1/(w.xi) into cone polynomials over bases of directions;
//! M_Xi is a signed sum of shifted truncated powers.

pub use crate::derive::cone::ConeTerm;
use crate::derive::piece_tables::PieceTables;
use crate::derive::spline::SplineFacts;
use crate::math::exact::{binomial, factorial, Q};
use crate::math::linalg::{inverse, mat_vec_q, rank, solve, to_q, IVec, QVec};
use crate::math::poly::{tensor_to_poly, Poly};
use std::collections::BTreeMap;
use std::sync::Arc;

/// phi(x) = |det G| * sum_sigma w_sigma * T(x + c - sigma), T = sum of cone terms.
#[derive(Clone, Debug)]
pub struct PpForm {
    /// Dimension s.
    pub dim: usize,
    /// Polynomial degree of the pieces.
    pub degree: usize,
    /// The cone terms whose sum is the truncated power T.
    pub terms: Vec<ConeTerm>,
    /// (sigma, w_sigma): merged shifts of the truncated power.
    pub shifts: Vec<(IVec, Q)>,
    /// c' = (1/2) sum of the flipped directions.
    pub center: QVec,
    /// |det G|.
    pub scale: Q,
    /// Integer tables for the fast path of [`PpForm::local_piece`]; `None`
    /// when they do not fit `i128` (the rational path is used then).
    pub(crate) tables: Option<Arc<PieceTables>>,
}

impl PpForm {
    /// The PP-form of the spline, scaled by |det G| (with integer tables when they fit).
    pub fn new(facts: &SplineFacts, lattice_det: i64) -> PpForm {
        let s = facts.dim;
        // Flipped distinct directions (first non-zero entry positive: all lie in
        // one open half-space) with multiplicities.
        let dirs: Vec<IVec> = facts.distinct.iter().map(|(v, _)| v.clone()).collect();
        let mult: Vec<u32> = facts.distinct.iter().map(|(_, m)| *m as u32).collect();
        let terms = partial_fractions(&dirs, &mult, s);
        // Shifts: sum over k_d in 0..=mu_d of prod (-1)^k C(mu, k), shift sum k_d d.
        let mut shifts: BTreeMap<IVec, Q> = BTreeMap::new();
        shifts.insert(vec![0; s], Q::one());
        for (d, &mu) in dirs.iter().zip(&mult) {
            let mut next: BTreeMap<IVec, Q> = BTreeMap::new();
            for (sh, w) in &shifts {
                for k in 0..=mu {
                    let sign = if k % 2 == 0 { Q::one() } else { -Q::one() };
                    let c = w * &(sign * binomial(mu, k));
                    let ns: IVec = sh.iter().zip(d).map(|(a, b)| a + b * k as i64).collect();
                    *next.entry(ns).or_insert_with(Q::zero) += &c;
                }
            }
            shifts = next.into_iter().filter(|(_, w)| !w.is_zero()).collect();
        }
        let center =
            (0..s).map(|i| Q::frac(dirs.iter().zip(&mult).map(|(d, &m)| d[i] * m as i64).sum::<i64>(), 2)).collect();
        let mut pp = PpForm {
            dim: s,
            degree: facts.degree,
            terms,
            shifts: shifts.into_iter().collect(),
            center,
            scale: Q::int(lattice_det),
            tables: None,
        };
        pp.tables = PieceTables::new(&pp.terms, &pp.shifts, pp.dim, pp.degree);
        pp
    }

    /// phi at a point off the knot planes (exact).
    pub fn phi(&self, x: &[Q]) -> Q {
        let y: QVec = x.iter().zip(&self.center).map(|(a, b)| a + b).collect();
        let mut acc = Q::zero();
        for (sigma, w) in &self.shifts {
            let ys: QVec = y.iter().zip(sigma).map(|(a, b)| a - &Q::int(*b)).collect();
            for term in &self.terms {
                let t = mat_vec_q(&term.inv, &ys);
                if t.iter().all(|ti| ti.is_positive()) {
                    let mut v = &term.coef * w;
                    for (ti, &p) in t.iter().zip(&term.powers) {
                        v = v * ti.pow(p);
                    }
                    acc += &v;
                }
            }
        }
        acc * &self.scale
    }

    /// The polynomial of u -> phi(origin + u - j) on the region of phi that
    /// contains `interior - j` (interior: any point of the cell strictly inside),
    /// in local coordinates u = x - origin.
    pub fn local_piece(&self, origin: &[Q], interior: &[Q], j: &[i64]) -> Poly {
        let s = self.dim;
        // y = x - j + c = u + (origin - j + c)
        let base: QVec = (0..s).map(|i| &(&origin[i] - &Q::int(j[i])) + &self.center[i]).collect();
        let py: QVec = (0..s).map(|i| &(&interior[i] - &Q::int(j[i])) + &self.center[i]).collect();
        if let Some(p) = self.tables.as_ref().and_then(|t| t.piece(&base, &py, &self.scale)) {
            return p;
        }
        self.rational_piece(&base, &py)
    }

    /// [`PpForm::local_piece`] entirely in rationals (the fallback when the
    /// integer tables overflow, and the reference they are tested against).
    pub fn local_piece_rational(&self, origin: &[Q], interior: &[Q], j: &[i64]) -> Poly {
        let s = self.dim;
        let base: QVec = (0..s).map(|i| &(&origin[i] - &Q::int(j[i])) + &self.center[i]).collect();
        let py: QVec = (0..s).map(|i| &(&interior[i] - &Q::int(j[i])) + &self.center[i]).collect();
        self.rational_piece(&base, &py)
    }

    fn rational_piece(&self, base: &[Q], py: &[Q]) -> Poly {
        let s = self.dim;
        let mut out = Poly::zero(s, self.degree);
        for term in &self.terms {
            let dims: Vec<usize> = term.powers.iter().map(|&p| p as usize + 1).collect();
            let size: usize = dims.iter().product();
            let mut tensor = vec![Q::zero(); size];
            let mut any = false;
            for (sigma, w) in &self.shifts {
                let sq = to_q(sigma);
                let ys: QVec = py.iter().zip(&sq).map(|(a, b)| a - b).collect();
                let t = mat_vec_q(&term.inv, &ys);
                if !t.iter().all(|ti| ti.is_positive()) {
                    continue;
                }
                any = true;
                // t = V^-1 u + V^-1 (base - sigma) =: t' - tau with t' = V^-1 u + V^-1 base.
                let tau = mat_vec_q(&term.inv, &sq);
                // prod_v (t'_v - tau_v)^p_v as a tensor in t'.
                let factors: Vec<Vec<Q>> = term
                    .powers
                    .iter()
                    .zip(&tau)
                    .map(|(&p, tv)| {
                        let m = -tv.clone();
                        (0..=p).map(|k| binomial(p, k) * m.pow(p - k)).collect()
                    })
                    .collect();
                accumulate_outer(&mut tensor, &factors, &dims, w);
            }
            if !any {
                continue;
            }
            let b = mat_vec_q(&term.inv, base);
            let p = tensor_to_poly(&tensor, &dims, &term.inv, &b, s, self.degree);
            out.add_scaled(&p, &term.coef);
        }
        out.scale(&self.scale)
    }
}

/// tensor += w * (outer product of the factor vectors).
fn accumulate_outer(tensor: &mut [Q], factors: &[Vec<Q>], dims: &[usize], w: &Q) {
    let mut idx = vec![0usize; dims.len()];
    for slot in tensor.iter_mut() {
        let mut v = w.clone();
        for (f, &i) in factors.iter().zip(&idx) {
            if f[i].is_zero() {
                v = Q::zero();
                break;
            }
            v *= &f[i];
        }
        if !v.is_zero() {
            *slot += &v;
        }
        for k in (0..dims.len()).rev() {
            idx[k] += 1;
            if idx[k] < dims[k] {
                break;
            }
            idx[k] = 0;
        }
    }
}

/// A circuit of a support set: the extra direction and its coordinates in the basis.
type Circuit = (usize, Vec<(usize, Q)>);

/// Splits prod_d 1/(w.d)^mu_d into terms over bases: returns cone terms.
fn partial_fractions(dirs: &[IVec], mult: &[u32], s: usize) -> Vec<ConeTerm> {
    let n = dirs.len();
    let mut work: BTreeMap<Vec<u32>, Q> = BTreeMap::new();
    work.insert(mult.to_vec(), Q::one());
    let mut done: BTreeMap<Vec<u32>, Q> = BTreeMap::new();
    // Circuit cache per support set.
    let mut circuits: BTreeMap<Vec<usize>, Circuit> = BTreeMap::new();
    while let Some((exps, c)) = work.pop_first() {
        if c.is_zero() {
            continue;
        }
        let support: Vec<usize> = (0..n).filter(|&k| exps[k] > 0).collect();
        if support.len() == s {
            *done.entry(exps).or_insert_with(Q::zero) += &c;
            continue;
        }
        let (i, nu) = circuits.entry(support.clone()).or_insert_with(|| circuit(dirs, &support, s)).clone();
        // 1 = sum_{k != i} nu_k (w.d_k) / (w.d_i)
        for (k, nk) in &nu {
            let mut e = exps.clone();
            e[i] += 1;
            e[*k] -= 1;
            *work.entry(e).or_insert_with(Q::zero) += &(&c * nk);
        }
    }
    done.into_iter()
        .filter(|(_, c)| !c.is_zero())
        .map(|(exps, c)| {
            let basis: Vec<usize> = (0..n).filter(|&k| exps[k] > 0).collect();
            let rows: Vec<QVec> = (0..s).map(|r| basis.iter().map(|&k| Q::int(dirs[k][r])).collect()).collect();
            let inv = inverse(&rows).expect(
                "every support met spans R^s (a circuit step drops a replaceable direction): s of them are a basis",
            );
            let det = crate::math::linalg::det(&rows).abs();
            let powers: Vec<u32> = basis.iter().map(|&k| exps[k] - 1).collect();
            let mut coef = c / &det;
            for &p in &powers {
                coef = coef / &factorial(p);
            }
            ConeTerm { inv, powers, coef }
        })
        .collect()
}

/// For a spanning support set with more than s directions: the first s
/// independent ones B (in order) and the first other one, e = sum_b lambda_b b.
/// Returns (e, [(b, lambda_b)]) so that w.d_e = sum lambda_b (w.d_b).
/// The choice depends only on the support, which makes the splitting terminate.
fn circuit(dirs: &[IVec], support: &[usize], s: usize) -> (usize, Vec<(usize, Q)>) {
    let mut basis: Vec<usize> = Vec::new();
    for &k in support {
        let mut cand: Vec<QVec> = basis.iter().map(|&b| to_q(&dirs[b])).collect();
        cand.push(to_q(&dirs[k]));
        if basis.len() < s && rank(&cand) == cand.len() {
            basis.push(k);
        }
    }
    let extra = support
        .iter()
        .copied()
        .find(|k| !basis.contains(k))
        .expect("circuit is called on spanning supports of more than s directions, and the basis holds only s");
    let rows: Vec<QVec> = (0..s).map(|r| basis.iter().map(|&b| Q::int(dirs[b][r])).collect()).collect();
    let lambda = solve(&rows, &to_q(&dirs[extra]))
        .expect("the basis is s independent directions of a spanning support: its matrix is invertible");
    let nu = basis.iter().zip(lambda).filter(|(_, l)| !l.is_zero()).map(|(&b, l)| (b, l)).collect();
    (extra, nu)
}
