//! The point symmetry group P of a filter: signed permutation matrices R with
//! R L = L and R Xi = Xi up to the sign of each column.

use crate::derive::spline::sign_normal;
use crate::math::linalg::{mat_vec_i, IVec};
use crate::spec::Filter;

/// A signed permutation matrix, stored as rows.
pub type SignedPerm = Vec<IVec>;

/// All signed permutation matrices of size n, identity first.
pub fn signed_permutations(n: usize) -> Vec<SignedPerm> {
    fn perms(n: usize) -> Vec<Vec<usize>> {
        if n == 0 {
            return vec![vec![]];
        }
        let mut out = Vec::new();
        for p in perms(n - 1) {
            for pos in 0..=p.len() {
                let mut q = p.clone();
                q.insert(pos, n - 1);
                out.push(q);
            }
        }
        out
    }
    let mut ps = perms(n);
    ps.sort();
    let mut out = Vec::new();
    for p in ps {
        for signs in 0..(1u32 << n) {
            let m: SignedPerm = (0..n)
                .map(|i| {
                    let mut row = vec![0; n];
                    row[p[i]] = if signs & (1 << i) != 0 { -1 } else { 1 };
                    row
                })
                .collect();
            out.push(m);
        }
    }
    out
}

/// P for the filter, in a fixed order (identity first).
pub fn point_group(filter: &Filter) -> Vec<SignedPerm> {
    let dim = filter.dim();
    let mut key: Vec<IVec> = filter.directions.iter().map(|d| sign_normal(d)).collect();
    key.sort();
    signed_permutations(dim)
        .into_iter()
        .filter(|r| {
            filter.lattice.generators.iter().all(|g| filter.lattice.contains(&mat_vec_i(r, g))) && {
                let mut img: Vec<IVec> = filter.directions.iter().map(|d| sign_normal(&mat_vec_i(r, d))).collect();
                img.sort();
                img == key
            }
        })
        .collect()
}

/// R^T (the inverse of a signed permutation).
pub fn inverse(r: &SignedPerm) -> SignedPerm {
    crate::math::linalg::transpose(r)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::spec::catalog;

    #[test]
    fn group_orders() {
        assert_eq!(signed_permutations(3).len(), 48);
        assert_eq!(point_group(&catalog::get("cc_tricubic").unwrap()).len(), 48);
        assert_eq!(point_group(&catalog::get("bcc8").unwrap()).len(), 48);
        assert_eq!(point_group(&catalog::get("zp").unwrap()).len(), 8);
        // Courant: (1,0),(0,1),(1,1): swapping x,y and x,y -> -x,-y keep it.
        assert_eq!(point_group(&catalog::get("courant").unwrap()).len(), 4);
    }
}
