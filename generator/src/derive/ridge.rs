//! The linear-form (ridge) form of a reference piece (docs/EVALUATION_FORMS.md §3):
//! the truncated-power derivation writes every cone polynomial as a product
//! of powers of knot-plane linear forms, t_v = inv_v . y. Kept unexpanded and
//! summed over the stencil, a piece is
//!
//! `s(u) = sum_g (sum_k W_g[k] c_k) * prod_{(f, p) in g} L_f(u)^p`,
//!
//! with L_f(u) = n_f . u + b_f affine forms of primitive integer normals
//! (first non-zero entry positive) and W_g exact weights of the stencil
//! samples, grouped by equal products: the shape of Kim & Lee's published
//! bcc7 formula (terms like `(x+y)^3 (2+x-y) (c10 - c20)`). Everything is exact.

use crate::derive::pieces::PpForm;
use crate::math::exact::Q;
use crate::math::linalg::{mat_vec_q, primitive_of_rational, to_q, IVec, QVec};
use crate::math::poly::Poly;
use std::collections::BTreeMap;

/// An affine form n . u + b of the local coordinates u.
#[derive(Clone, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct Affine {
    /// Primitive integer normal, first non-zero entry positive.
    pub normal: IVec,
    /// The constant b.
    pub offset: Q,
}

/// One product of powers of affine forms H(u) times a multiplier that is a
/// combination of the samples, constant (`linear` empty) or affine in u:
/// `H(u) * (weights . c + sum_j (linear[j] . c) u_j)`.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct RidgeGroup {
    /// (index into [`RidgeForm::affine`], power >= 1), sorted by index,
    /// each index at most once; empty for the constant 1.
    pub factors: Vec<(usize, u32)>,
    /// Exact weight of each stencil sample (stencil order) in the constant
    /// part of the multiplier.
    pub weights: Vec<Q>,
    /// Empty, or one row of sample weights per coordinate u_j: the linear
    /// part of the multiplier (after [`RidgeForm::merged`]).
    pub linear: Vec<Vec<Q>>,
}

impl RidgeGroup {
    /// The multiplier's rows that are not all zero, in emission order:
    /// the constant row, then the linear rows by coordinate.
    pub fn rows(&self) -> impl Iterator<Item = (Option<usize>, &Vec<Q>)> {
        std::iter::once((None, &self.weights))
            .chain(self.linear.iter().enumerate().map(|(j, r)| (Some(j), r)))
            .filter(|(_, r)| r.iter().any(|x| !x.is_zero()))
    }
}

/// A piece as a sum of products of powers of affine forms (see the module doc).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct RidgeForm {
    /// The distinct affine forms, sorted.
    pub affine: Vec<Affine>,
    /// The distinct products, in a deterministic order (sorted by factors).
    pub groups: Vec<RidgeGroup>,
}

/// A product's factors: (affine form index, power), sorted.
type Factors = Vec<(usize, u32)>;

/// (n, lambda) with a = lambda n, n primitive integer, first non-zero entry positive.
fn normalise(a: &[Q]) -> (IVec, Q) {
    let n = primitive_of_rational(a).expect("rows of an inverse basis matrix are non-zero and fit i64");
    let i = n.iter().position(|x| *x != 0).expect("a primitive vector has a non-zero entry");
    let lambda = &a[i] / &Q::int(n[i]);
    (n, lambda)
}

impl RidgeForm {
    /// The ridge form of the piece of `pp` on the cell with interior point
    /// `interior`, in local coordinates u = x - origin, for the stencil
    /// points `stencil` (absolute lattice points j: sample k multiplies
    /// phi(origin + u - j_k)). The active cone terms are those of
    /// [`PpForm::local_piece_rational`], so the expansion of each sample's
    /// weights is that piece's polynomial.
    pub fn new(pp: &PpForm, origin: &[Q], interior: &[Q], stencil: &[IVec]) -> RidgeForm {
        let s = pp.dim;
        let nst = stencil.len();
        // Product (sorted (affine, power)) -> weight per stencil index.
        let mut products: BTreeMap<Vec<(Affine, u32)>, Vec<Q>> = BTreeMap::new();
        for (k, j) in stencil.iter().enumerate() {
            let base: QVec = (0..s).map(|i| &(&origin[i] - &Q::int(j[i])) + &pp.center[i]).collect();
            let py: QVec = (0..s).map(|i| &(&interior[i] - &Q::int(j[i])) + &pp.center[i]).collect();
            for term in &pp.terms {
                for (sigma, w) in &pp.shifts {
                    let sq = to_q(sigma);
                    let ys: QVec = py.iter().zip(&sq).map(|(a, b)| a - b).collect();
                    if !mat_vec_q(&term.inv, &ys).iter().all(|t| t.is_positive()) {
                        continue;
                    }
                    let shifted: QVec = base.iter().zip(&sq).map(|(a, b)| a - b).collect();
                    let beta = mat_vec_q(&term.inv, &shifted);
                    let mut weight = &(&pp.scale * w) * &term.coef;
                    let mut key: Vec<(Affine, u32)> = Vec::new();
                    for ((row, b), &p) in term.inv.iter().zip(&beta).zip(&term.powers) {
                        if p == 0 {
                            continue;
                        }
                        // inv_v . u + beta_v = lambda (n . u + beta_v / lambda)
                        let (normal, lambda) = normalise(row);
                        weight = weight * lambda.pow(p);
                        key.push((Affine { normal, offset: b / &lambda }, p));
                    }
                    key.sort();
                    // Equal forms within one product (two basis rows are never
                    // parallel, but merge defensively): add their powers.
                    let mut merged: Vec<(Affine, u32)> = Vec::new();
                    for (a, p) in key {
                        match merged.last_mut() {
                            Some((b, q)) if *b == a => *q += p,
                            _ => merged.push((a, p)),
                        }
                    }
                    products.entry(merged).or_insert_with(|| vec![Q::zero(); nst])[k] += &weight;
                }
            }
        }
        products.retain(|_, w| w.iter().any(|x| !x.is_zero()));
        let mut affine: Vec<Affine> = products.keys().flat_map(|p| p.iter().map(|(a, _)| a.clone())).collect();
        affine.sort();
        affine.dedup();
        let index = |a: &Affine| affine.binary_search(a).expect("every factor's form is collected above");
        let mut groups: Vec<RidgeGroup> = products
            .into_iter()
            .map(|(key, weights)| {
                let mut factors: Vec<(usize, u32)> = key.iter().map(|(a, p)| (index(a), *p)).collect();
                factors.sort();
                RidgeGroup { factors, weights, linear: vec![] }
            })
            .collect();
        groups.sort_by(|a, b| a.factors.cmp(&b.factors));
        RidgeForm { affine, groups }
    }

    /// Every non-zero multiplier row of every group, in emission order
    /// (groups in order, each by [`RidgeGroup::rows`]).
    pub fn rows(&self) -> Vec<Vec<Q>> {
        self.groups.iter().flat_map(|g| g.rows().map(|(_, r)| r.clone())).collect()
    }

    /// Merges the groups that share all factors but one linear one, H * L_g
    /// with L_g = n_g . u + b_g, into H * (sum_g W_g (n_g . u + b_g)): one
    /// product H with an affine multiplier (the shape of Kim & Lee's
    /// `(x-y)^3 (4(c10 - c21) - 2z(...) - (x+y)(...))`). Greedy: the H shared
    /// by most unmerged groups first, while at least three share it. Then,
    /// where H L_f (for a factor f of H) is itself a group, the part of the
    /// multiplier along n_f moves into that group (one coordinate row fewer)
    /// when that does not add non-zero weights. Exact: the same polynomials.
    pub fn merged(&self) -> RidgeForm {
        let s = self.affine.first().map(|a| a.normal.len()).unwrap_or(0);
        let nst = self.groups.first().map(|g| g.weights.len()).unwrap_or(0);
        let zero = || vec![Q::zero(); nst];
        let axpy = |y: &mut Vec<Q>, a: &Q, x: &[Q]| {
            if !a.is_zero() {
                for (yi, xi) in y.iter_mut().zip(x) {
                    if !xi.is_zero() {
                        *yi += &(a * xi);
                    }
                }
            }
        };
        // Candidate H for each group: its factors without one power-1 factor.
        let mut by_h: BTreeMap<Factors, Vec<(usize, usize)>> = BTreeMap::new();
        for (g, grp) in self.groups.iter().enumerate() {
            for (i, &(f, p)) in grp.factors.iter().enumerate() {
                if p == 1 {
                    let mut h = grp.factors.clone();
                    h.remove(i);
                    by_h.entry(h).or_default().push((g, f));
                }
            }
        }
        let mut out: BTreeMap<Factors, (Vec<Q>, Vec<Vec<Q>>)> = BTreeMap::new();
        let mut assigned = vec![false; self.groups.len()];
        loop {
            let best = by_h
                .iter()
                .map(|(h, m)| (m.iter().filter(|(g, _)| !assigned[*g]).count(), h))
                .max_by(|a, b| a.0.cmp(&b.0).then_with(|| b.1.cmp(a.1)));
            let Some((count, h)) = best else { break };
            if count < 3 {
                break;
            }
            let h = h.clone();
            let entry = out.entry(h.clone()).or_insert_with(|| (zero(), vec![zero(); s]));
            if entry.1.is_empty() {
                entry.1 = vec![zero(); s];
            }
            for &(g, f) in &by_h[&h] {
                if assigned[g] {
                    continue;
                }
                assigned[g] = true;
                let a = &self.affine[f];
                let w = &self.groups[g].weights;
                axpy(&mut entry.0, &a.offset, w);
                for j in 0..s {
                    axpy(&mut entry.1[j], &Q::int(a.normal[j]), w);
                }
            }
            if let Some(g) = self.groups.iter().position(|grp| grp.factors == h) {
                if !assigned[g] {
                    assigned[g] = true;
                    axpy(&mut entry.0, &Q::one(), &self.groups[g].weights);
                }
            }
        }
        for (g, grp) in self.groups.iter().enumerate() {
            if !assigned[g] {
                let entry = out.entry(grp.factors.clone()).or_insert_with(|| (zero(), vec![]));
                axpy(&mut entry.0, &Q::one(), &grp.weights);
            }
        }
        // Move the part along a factor's normal into the group H L_f.
        let nnz = |rows: &[&Vec<Q>]| rows.iter().map(|r| r.iter().filter(|x| !x.is_zero()).count()).sum::<usize>();
        let keys: Vec<Factors> = out.keys().cloned().collect();
        for h in keys {
            if out[&h].1.is_empty() {
                continue;
            }
            let mut best: Option<(usize, usize, Factors, usize)> = None;
            for (i, &(f, p)) in h.iter().enumerate() {
                let mut target = h.clone();
                target[i].1 = p + 1;
                let Some(t) = out.get(&target) else { continue };
                let n = &self.affine[f].normal;
                let (c0, lin) = &out[&h];
                for j in (0..s).filter(|&j| n[j] != 0) {
                    let before = nnz(&[c0, &t.0]) + nnz(&lin.iter().collect::<Vec<_>>());
                    let (nc0, nt, nlin) = self.move_along(&h, i, j, c0, &t.0, lin);
                    let after = nnz(&[&nc0, &nt]) + nnz(&nlin.iter().collect::<Vec<_>>());
                    if after <= before && best.as_ref().is_none_or(|b| after < b.3) {
                        best = Some((i, j, target.clone(), after));
                    }
                }
            }
            if let Some((i, j, target, _)) = best {
                let (c0, lin) = out[&h].clone();
                let (nc0, nt, nlin) = self.move_along(&h, i, j, &c0, &out[&target].0, &lin);
                out.insert(h.clone(), (nc0, nlin));
                out.get_mut(&target).expect("the target was found above").0 = nt;
            }
        }
        let groups = out
            .into_iter()
            .map(|(factors, (weights, mut linear))| {
                if linear.iter().all(|r| r.iter().all(|x| x.is_zero())) {
                    linear.clear();
                }
                RidgeGroup { factors, weights, linear }
            })
            .filter(|g| g.rows().next().is_some())
            .collect();
        RidgeForm { affine: self.affine.clone(), groups }
    }

    /// Rewrites H (c0 + sum_i lin_i u_i) with u_j = (n . u - sum_{i != j} n_i u_i) / n_j,
    /// n the normal of factor `i` of H, and n . u H = H L_f - b_f H:
    /// returns (new c0, new constant row of H L_f, new linear rows).
    fn move_along(
        &self,
        h: &[(usize, u32)],
        i: usize,
        j: usize,
        c0: &[Q],
        target: &[Q],
        lin: &[Vec<Q>],
    ) -> (Vec<Q>, Vec<Q>, Vec<Vec<Q>>) {
        let a = &self.affine[h[i].0];
        let n = &a.normal;
        let c: Vec<Q> = lin[j].iter().map(|x| x / &Q::int(n[j])).collect();
        let nt: Vec<Q> = target.iter().zip(&c).map(|(t, x)| t + x).collect();
        let nc0: Vec<Q> = c0.iter().zip(&c).map(|(y, x)| y - &(&a.offset * x)).collect();
        let nlin: Vec<Vec<Q>> = (0..lin.len())
            .map(|k| {
                if k == j {
                    vec![Q::zero(); c.len()]
                } else {
                    lin[k].iter().zip(&c).map(|(y, x)| y - &(&Q::int(n[k]) * x)).collect()
                }
            })
            .collect();
        (nc0, nt, nlin)
    }

    /// The product polynomial of group `g` on the basis of degree `degree`.
    pub fn product(&self, g: usize, degree: usize) -> Poly {
        let s = self.affine.first().map(|a| a.normal.len()).unwrap_or(0);
        let mut p = Poly::constant(s, degree, Q::one());
        for &(f, pow) in &self.groups[g].factors {
            let a = &self.affine[f];
            let n = to_q(&a.normal);
            for _ in 0..pow {
                p = p.mul_affine(&n, &a.offset);
            }
        }
        p
    }

    /// Expands the form into one polynomial per stencil sample (exact):
    /// `sum_g (W_g[k] + sum_j linear_g[j][k] u_j) prod_g`. `dim` is the number of variables (the form of a
    /// zero piece has no affine forms to read it from).
    pub fn expand(&self, dim: usize, degree: usize) -> Vec<Poly> {
        let nst = self.groups.first().map(|g| g.weights.len()).unwrap_or(0);
        let mut out = vec![Poly::zero(dim, degree); nst];
        for g in 0..self.groups.len() {
            let p = self.product(g, degree);
            for (j, row) in self.groups[g].rows() {
                // H, or H u_j.
                let q = match j {
                    None => p.clone(),
                    Some(j) => {
                        let mut e = vec![Q::zero(); dim];
                        e[j] = Q::one();
                        p.mul_affine(&e, &Q::zero())
                    }
                };
                for (k, w) in row.iter().enumerate() {
                    if !w.is_zero() {
                        out[k].add_scaled(&q, w);
                    }
                }
            }
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use crate::derive::Derivation;
    use crate::spec::catalog;

    #[test]
    fn the_ridge_form_expands_to_every_stencil_polynomial() {
        for name in ["bcc7", "fcc6", "bcc8", "courant", "cc_tricubic", "zp", "bcc_linear"] {
            let d = Derivation::new(&catalog::get(name).unwrap()).unwrap();
            for r in 0..d.references.len() {
                let ridge = d.ridge(r);
                let polys = &d.forms(r).polys;
                let merged = ridge.merged();
                assert!(merged.groups.len() <= ridge.groups.len());
                for (form, what) in [(ridge, "plain"), (&merged, "merged")] {
                    let got = form.expand(d.facts.dim, d.facts.degree);
                    assert_eq!(got.len(), polys.len(), "{name} piece {r}: one polynomial per stencil point");
                    for (k, (a, b)) in got.iter().zip(polys).enumerate() {
                        assert_eq!(a, b, "{name} piece {r} stencil {k} ({what})");
                    }
                }
                if name == "bcc7" {
                    assert!(merged.groups.iter().any(|g| !g.linear.is_empty()), "bcc7 has H * affine groups");
                }
                assert!(!ridge.groups.is_empty(), "{name} piece {r}: a non-zero piece has terms");
                for g in &ridge.groups {
                    assert!(g.weights.iter().any(|w| !w.is_zero()), "{name}: zero groups are dropped");
                    assert!(g.factors.windows(2).all(|w| w[0].0 < w[1].0), "{name}: factors sorted, distinct");
                }
                for a in &ridge.affine {
                    let first = a.normal.iter().find(|x| **x != 0).unwrap();
                    assert!(*first > 0, "{name}: normals are normalised");
                }
            }
        }
    }

    #[test]
    fn a_wrong_weight_is_caught_by_the_expansion() {
        // The check above can fail: perturb one weight and the expansion differs.
        let d = Derivation::new(&catalog::get("bcc7").unwrap()).unwrap();
        let mut ridge = d.ridge(0).clone();
        let w = &mut ridge.groups[0].weights;
        let k = w.iter().position(|x| !x.is_zero()).unwrap();
        w[k] += &crate::math::exact::Q::frac(1, 1000);
        let got = ridge.expand(d.facts.dim, d.facts.degree);
        assert_ne!(got[k], d.forms(0).polys[k]);
        // And in a merged group's linear rows.
        let mut merged = d.ridge(0).merged();
        let g = merged.groups.iter().position(|g| !g.linear.is_empty()).unwrap();
        let row = merged.groups[g].linear.iter_mut().find(|r| r.iter().any(|x| !x.is_zero())).unwrap();
        let k = row.iter().position(|x| !x.is_zero()).unwrap();
        row[k] = crate::math::exact::Q::zero();
        assert_ne!(merged.expand(d.facts.dim, d.facts.degree)[k], d.forms(0).polys[k]);
    }
}
