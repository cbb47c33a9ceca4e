//! Scalar facts of a direction matrix: degree, approximation order,
//! continuity, support volume, centre, and the knot-plane normals.

use crate::math::exact::Q;
use crate::math::linalg::{det_columns, primitive, primitive_normal, IVec, QVec};
pub use crate::math::subsets;
use crate::spec::Filter;

/// What follows from the direction matrix alone.
#[derive(Clone, Debug)]
pub struct SplineFacts {
    /// Dimension s.
    pub dim: usize,
    /// The directions, as given (with repeats).
    pub directions: Vec<IVec>,
    /// Distinct directions up to sign (sign-normalised, primitive-free: the
    /// actual vectors), with multiplicities.
    pub distinct: Vec<(IVec, usize)>,
    /// Polynomial degree of the pieces: number of directions - s.
    pub degree: usize,
    /// Approximation order rho: the fewest directions off any knot hyperplane.
    pub approximation_order: usize,
    /// C^k continuity; -1 means discontinuous.
    pub continuity: i64,
    /// Volume of the support (the zonotope): the sum of |det| over every
    /// s-subset of directions.
    pub support_volume: i64,
    /// c = (1/2) sum xi: phi(x) = |det G| M(x + c).
    pub center: QVec,
    /// Primitive knot-plane normals, sorted.
    pub normals: Vec<IVec>,
}

/// Sign-normalises a vector (first non-zero entry positive).
pub fn sign_normal(v: &[i64]) -> IVec {
    if v.iter().find(|&&x| x != 0).copied().unwrap_or(0) < 0 {
        v.iter().map(|x| -x).collect()
    } else {
        v.to_vec()
    }
}

impl SplineFacts {
    /// Computes the facts of a validated filter.
    pub fn new(filter: &Filter) -> SplineFacts {
        let dim = filter.dim();
        let directions = filter.directions.clone();
        let mut distinct: Vec<(IVec, usize)> = Vec::new();
        for d in &directions {
            let n = sign_normal(d);
            match distinct.iter_mut().find(|(v, _)| *v == n) {
                Some((_, c)) => *c += 1,
                None => distinct.push((n, 1)),
            }
        }
        distinct.sort();
        // Knot normals: hyperplanes spanned by s-1 independent distinct directions.
        let dvecs: Vec<&[i64]> = distinct.iter().map(|(v, _)| v.as_slice()).collect();
        let mut normals: Vec<IVec> = Vec::new();
        for sub in subsets(dvecs.len(), dim - 1) {
            let vs: Vec<&[i64]> = sub.iter().map(|&i| dvecs[i]).collect();
            if let Some(n) = primitive_normal(&vs, dim) {
                if !normals.contains(&n) {
                    normals.push(n);
                }
            }
        }
        normals.sort();
        // rho = min over knot hyperplanes of the number of directions off it.
        let approximation_order = normals
            .iter()
            .map(|n| directions.iter().filter(|d| crate::math::linalg::dot_i(n, d) != 0).count())
            .min()
            .unwrap_or(0);
        let support_volume = subsets(directions.len(), dim)
            .iter()
            .map(|sub| {
                let cols: Vec<&[i64]> = sub.iter().map(|&i| directions[i].as_slice()).collect();
                det_columns(&cols)
                    .expect("directions are within ±64 (Filter::new) and s <= 3: |det| <= 3! * 64^3")
                    .abs()
            })
            .sum();
        let center = (0..dim).map(|i| Q::frac(directions.iter().map(|d| d[i]).sum::<i64>(), 2)).collect();
        SplineFacts {
            dim,
            degree: directions.len() - dim,
            approximation_order,
            continuity: approximation_order as i64 - 2,
            support_volume,
            center,
            normals,
            distinct,
            directions,
        }
    }

    /// Half-width of the centred support along normal n: sum |n.xi| / 2.
    pub fn support_half_width(&self, n: &[i64]) -> Q {
        Q::frac(self.directions.iter().map(|d| crate::math::linalg::dot_i(n, d).abs()).sum(), 2)
    }

    /// Is y strictly inside the centred support (the zonotope)?
    pub fn in_open_support(&self, y: &[Q]) -> bool {
        self.normals.iter().all(|n| crate::math::linalg::dot_iq(n, y).abs() < self.support_half_width(n))
    }

    /// Is y in the closed centred support?
    pub fn in_closed_support(&self, y: &[Q]) -> bool {
        self.normals.iter().all(|n| crate::math::linalg::dot_iq(n, y).abs() <= self.support_half_width(n))
    }
}

/// Primitive direction of a vector (for grouping parallel directions).
///
/// # Panics
///
/// For the zero vector.
pub fn primitive_direction(v: &[i64]) -> IVec {
    primitive(v).expect("v is non-zero (the precondition; Filter::new refuses zero directions)")
}
