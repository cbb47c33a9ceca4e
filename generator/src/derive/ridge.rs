//! The linear-form (ridge) form of a reference piece (EVALUATION_FORMS.md §3):
//! the truncated-power derivation writes every cone polynomial as a product
//! of powers of knot-plane linear forms, t_v = inv_v . y. Kept unexpanded and
//! summed over the stencil, a piece is
//!
//! s(u) = sum_g (sum_k W_g[k] c_k) * prod_{(f, p) in g} L_f(u)^p,
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

/// One product of powers of affine forms, with its weight per stencil sample.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct RidgeGroup {
    /// (index into [`RidgeForm::affine`], power >= 1), sorted by index,
    /// each index at most once; empty for the constant 1.
    pub factors: Vec<(usize, u32)>,
    /// Exact weight of each stencil sample (stencil order), not all zero.
    pub weights: Vec<Q>,
}

/// A piece as a sum of products of powers of affine forms (see the module doc).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct RidgeForm {
    /// The distinct affine forms, sorted.
    pub affine: Vec<Affine>,
    /// The distinct products, in a deterministic order (sorted by factors).
    pub groups: Vec<RidgeGroup>,
}

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
                RidgeGroup { factors, weights }
            })
            .collect();
        groups.sort_by(|a, b| a.factors.cmp(&b.factors));
        RidgeForm { affine, groups }
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
    /// sum_g W_g[k] prod_g. `dim` is the number of variables (the form of a
    /// zero piece has no affine forms to read it from).
    pub fn expand(&self, dim: usize, degree: usize) -> Vec<Poly> {
        let nst = self.groups.first().map(|g| g.weights.len()).unwrap_or(0);
        let mut out = vec![Poly::zero(dim, degree); nst];
        for g in 0..self.groups.len() {
            let p = self.product(g, degree);
            for (k, w) in self.groups[g].weights.iter().enumerate() {
                if !w.is_zero() {
                    out[k].add_scaled(&p, w);
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
                let got = ridge.expand(d.facts.dim, d.facts.degree);
                assert_eq!(got.len(), polys.len(), "{name} piece {r}: one polynomial per stencil point");
                for (k, (a, b)) in got.iter().zip(polys).enumerate() {
                    assert_eq!(a, b, "{name} piece {r} stencil {k}");
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
    }
}
