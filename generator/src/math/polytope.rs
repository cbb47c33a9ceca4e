//! Exact convex polytopes in H- and V-representation, cut by hyperplanes.
//! Sizes here are tiny (a unit cube cut by a few dozen planes), so vertex
//! enumeration by s-subsets of facets is simple and fast enough.

use crate::math::exact::Q;
use crate::math::linalg::{dot_q, rank, solve, sub_q, QVec};
use crate::math::subsets;

/// The half-space n . x <= b.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct HalfSpace {
    /// The normal n.
    pub normal: QVec,
    /// The bound b.
    pub bound: Q,
}

impl HalfSpace {
    /// bound - normal . x: non-negative inside.
    pub fn slack(&self, x: &[Q]) -> Q {
        &self.bound - &dot_q(&self.normal, x)
    }
}

/// A bounded, full-dimensional convex polytope.
#[derive(Clone, Debug)]
pub struct Polytope {
    /// Facets only (no redundant half-spaces).
    pub facets: Vec<HalfSpace>,
    /// Vertices, sorted.
    pub vertices: Vec<QVec>,
    /// For each vertex, the bit set of facets tight at it (incidence), which
    /// lets a split find edges combinatorially instead of re-enumerating.
    incidence: Vec<u128>,
}

impl Polytope {
    /// The box lo + `[0,1]^s`.
    pub fn unit_cube(lo: &[Q]) -> Polytope {
        let s = lo.len();
        let mut hs = Vec::new();
        for i in 0..s {
            let mut e = vec![Q::zero(); s];
            e[i] = Q::one();
            hs.push(HalfSpace { normal: e.clone(), bound: &lo[i] + &Q::one() });
            let neg: QVec = e.iter().map(|x| -x).collect();
            hs.push(HalfSpace { normal: neg, bound: -lo[i].clone() });
        }
        Polytope::from_halfspaces(hs).expect("the 2s facets of a box bound a full-dimensional polytope")
    }

    /// The ambient dimension s.
    pub fn dim(&self) -> usize {
        self.vertices[0].len()
    }

    /// Builds from half-spaces by vertex enumeration; None if the result is
    /// not full-dimensional.
    pub fn from_halfspaces(hs: Vec<HalfSpace>) -> Option<Polytope> {
        let s = hs[0].normal.len();
        let mut verts: Vec<QVec> = Vec::new();
        for sub in subsets(hs.len(), s) {
            let m: Vec<QVec> = sub.iter().map(|&i| hs[i].normal.clone()).collect();
            let b: QVec = sub.iter().map(|&i| hs[i].bound.clone()).collect();
            let Some(x) = solve(&m, &b) else { continue };
            if hs.iter().all(|h| !h.slack(&x).is_negative()) && !verts.contains(&x) {
                verts.push(x);
            }
        }
        if verts.len() <= s {
            return None;
        }
        let diffs: Vec<QVec> = verts[1..].iter().map(|v| sub_q(v, &verts[0])).collect();
        if rank(&diffs) < s {
            return None;
        }
        // Keep facets: half-spaces tight on an affinely (s-1)-dimensional vertex set.
        let mut facets: Vec<HalfSpace> = Vec::new();
        for h in hs {
            let tight: Vec<&QVec> = verts.iter().filter(|v| h.slack(v).is_zero()).collect();
            if tight.len() < s {
                continue;
            }
            let d: Vec<QVec> = tight[1..].iter().map(|v| sub_q(v, tight[0])).collect();
            if rank(&d) == s - 1 && !facets.iter().any(|f| same_halfspace(f, &h)) {
                facets.push(h);
            }
        }
        assert!(facets.len() <= 128, "too many facets for the incidence bit set");
        verts.sort();
        let incidence = verts
            .iter()
            .map(|v| {
                facets.iter().enumerate().filter(|(_, f)| f.slack(v).is_zero()).fold(0u128, |m, (i, _)| m | 1 << i)
            })
            .collect();
        Some(Polytope { facets, vertices: verts, incidence })
    }

    /// Does the plane n . x = a cut the interior?
    pub fn is_cut_by(&self, normal: &[Q], a: &Q) -> bool {
        let mut below = false;
        let mut above = false;
        for v in &self.vertices {
            match dot_q(normal, v).cmp(a) {
                std::cmp::Ordering::Less => below = true,
                std::cmp::Ordering::Greater => above = true,
                _ => {}
            }
            if below && above {
                return true;
            }
        }
        false
    }

    /// Splits by n . x = a into the parts with n . x <= a and >= a; returns
    /// None when the plane does not cut the interior.
    pub fn split(&self, normal: &[Q], a: &Q) -> Option<(Polytope, Polytope)> {
        let vals: Vec<Q> = self.vertices.iter().map(|v| &dot_q(normal, v) - a).collect();
        if !(vals.iter().any(|v| v.is_negative()) && vals.iter().any(|v| v.is_positive())) {
            return None;
        }
        let s = self.dim();
        // Edges crossing the plane: u < 0 < v, joined by an edge when their
        // common facets (>= s-1 of them) are tight at no other vertex.
        let mut cuts: Vec<(QVec, u128)> = Vec::new();
        for i in 0..self.vertices.len() {
            if !vals[i].is_negative() {
                continue;
            }
            for j in 0..self.vertices.len() {
                if !vals[j].is_positive() {
                    continue;
                }
                let common = self.incidence[i] & self.incidence[j];
                if (common.count_ones() as usize) < s - 1 {
                    continue;
                }
                let other = (0..self.vertices.len()).any(|k| k != i && k != j && self.incidence[k] & common == common);
                if other {
                    continue;
                }
                let t = &vals[i] / &(&vals[i] - &vals[j]);
                let x: QVec =
                    self.vertices[i].iter().zip(&self.vertices[j]).map(|(a, b)| a + &(&t * &(b - a))).collect();
                cuts.push((x, common));
            }
        }
        let new_bit = 1u128 << self.facets.len();
        let part = |keep_negative: bool| -> Polytope {
            let mut verts: Vec<(QVec, u128)> = Vec::new();
            for (i, v) in self.vertices.iter().enumerate() {
                let on = vals[i].is_zero();
                if on || vals[i].is_negative() == keep_negative {
                    verts.push((v.clone(), self.incidence[i] | if on { new_bit } else { 0 }));
                }
            }
            verts.extend(cuts.iter().map(|(x, c)| (x.clone(), c | new_bit)));
            let mut facets = self.facets.clone();
            facets.push(if keep_negative {
                HalfSpace { normal: normal.to_vec(), bound: a.clone() }
            } else {
                HalfSpace { normal: normal.iter().map(|x| -x).collect(), bound: -a.clone() }
            });
            Polytope::compact(facets, verts, s)
        };
        Some((part(true), part(false)))
    }

    /// Drops facets tight at fewer than s vertices, renumbers incidence bits,
    /// sorts vertices.
    fn compact(facets: Vec<HalfSpace>, mut verts: Vec<(QVec, u128)>, s: usize) -> Polytope {
        let keep: Vec<usize> =
            (0..facets.len()).filter(|&f| verts.iter().filter(|(_, m)| m >> f & 1 == 1).count() >= s).collect();
        assert!(keep.len() < 128, "too many facets for the incidence bit set");
        for (_, m) in verts.iter_mut() {
            *m = keep.iter().enumerate().fold(0u128, |acc, (new, &old)| acc | ((*m >> old & 1) << new));
        }
        verts.sort_by(|a, b| a.0.cmp(&b.0));
        let facets = keep.iter().map(|&f| facets[f].clone()).collect();
        let (vertices, incidence) = verts.into_iter().unzip();
        Polytope { facets, vertices, incidence }
    }

    /// Vertex average: a point strictly inside.
    pub fn centroid(&self) -> QVec {
        let s = self.dim();
        let n = Q::int(self.vertices.len() as i64);
        (0..s).map(|i| self.vertices.iter().map(|v| v[i].clone()).sum::<Q>() / &n).collect()
    }

    /// Is x in the closed polytope?
    pub fn contains(&self, x: &[Q]) -> bool {
        self.facets.iter().all(|h| !h.slack(x).is_negative())
    }

    /// Does it have exactly s + 1 vertices?
    pub fn is_simplex(&self) -> bool {
        self.vertices.len() == self.dim() + 1
    }

    /// Exact volume via a fan triangulation from the first vertex over facets
    /// (recursively); used by tests and reports.
    pub fn volume(&self) -> Q {
        volume_of(&self.vertices, &self.facets)
    }
}

fn same_halfspace(a: &HalfSpace, b: &HalfSpace) -> bool {
    // Same iff positively proportional (including the bound).
    let s = a.normal.len();
    let Some(k) = (0..s).find(|&i| !a.normal[i].is_zero()) else {
        return false;
    };
    if b.normal[k].is_zero() {
        return false;
    }
    let r = &b.normal[k] / &a.normal[k];
    if !r.is_positive() {
        return false;
    }
    (0..s).all(|i| &a.normal[i] * &r == b.normal[i]) && &a.bound * &r == b.bound
}

fn volume_of(vertices: &[QVec], facets: &[HalfSpace]) -> Q {
    // Cone from the centroid over each facet: vol = sum (1/s) * dist * facet area.
    // Done exactly by triangulating each facet recursively in its own plane
    // is involved; instead use the simplex decomposition from the centroid
    // over a triangulation of the boundary built by pulling vertices.
    let s = vertices[0].len();
    let n = Q::int(vertices.len() as i64);
    let c: QVec = (0..s).map(|i| vertices.iter().map(|v| v[i].clone()).sum::<Q>() / &n).collect();
    let mut total = Q::zero();
    for f in facets {
        let on: Vec<QVec> = vertices.iter().filter(|v| f.slack(v).is_zero()).cloned().collect();
        for simplex in triangulate_facet(&on, s) {
            let rows: Vec<QVec> = simplex.iter().map(|v| sub_q(v, &c)).collect();
            total += crate::math::linalg::det(&rows).abs();
        }
    }
    total / crate::math::exact::factorial(s as u32)
}

/// Triangulates a convex (s-1)-dimensional point set in R^s into (s-1)-simplices
/// (lists of s points) by fanning from its least point.
fn triangulate_facet(points: &[QVec], s: usize) -> Vec<Vec<QVec>> {
    let mut pts = points.to_vec();
    pts.sort();
    if s == 1 {
        return vec![vec![pts[0].clone()]];
    }
    if pts.len() == s {
        return vec![pts];
    }
    let apex = pts[0].clone();
    // Sub-facets of this facet not containing the apex: find maximal subsets
    // lying on a common (s-2)-flat that bounds the facet. Brute force over
    // (s-1)-subsets' affine hulls.
    let rest: Vec<QVec> = pts[1..].to_vec();
    let mut out = Vec::new();
    let mut seen: Vec<Vec<QVec>> = Vec::new();
    for sub in subsets(rest.len(), s - 1) {
        let base: Vec<QVec> = sub.iter().map(|&i| rest[i].clone()).collect();
        // The flat through `base` (dimension s-2) must be a boundary of the facet:
        // all points on one side within the facet's plane. Test with the
        // affine functional given by the apex side.
        let d: Vec<QVec> = base[1..].iter().map(|v| sub_q(v, &base[0])).collect();
        if !d.is_empty() && rank(&d) < s - 2 {
            continue;
        }
        let flat: Vec<QVec> = rest
            .iter()
            .filter(|p| {
                let mut m = d.clone();
                m.push(sub_q(p, &base[0]));
                rank(&m) <= s - 2
            })
            .cloned()
            .collect();
        if seen.contains(&flat) {
            continue;
        }
        // Boundary check: every point of the facet lies weakly on one side of
        // the flat within the facet's plane, and the apex is strictly off it.
        let mut m_apex = d.clone();
        m_apex.push(sub_q(&apex, &base[0]));
        if rank(&m_apex) <= s - 2 {
            continue;
        }
        if !is_boundary_flat(&pts, &flat, &apex, s) {
            continue;
        }
        seen.push(flat.clone());
        for tri in triangulate_facet(&flat, s - 1).into_iter().filter(|t| t.len() == s - 1) {
            let mut simplex = vec![apex.clone()];
            simplex.extend(tri);
            out.push(simplex);
        }
    }
    out
}

/// Is `flat` (points on an (s-2)-flat) a face of the convex set `pts`
/// (all in one (s-1)-flat of R^s)? Checks that all points lie on one side
/// of the hyperplane (within the facet) through the flat.
fn is_boundary_flat(pts: &[QVec], flat: &[QVec], apex: &QVec, s: usize) -> bool {
    // Orientation of p relative to flat within the facet plane: sign of the
    // determinant of [flat directions..., p - f0, apex - f0] projected... use
    // the volume sign with an extra generic direction normal to the facet.
    let f0 = &flat[0];
    let mut dirs: Vec<QVec> = Vec::new();
    for p in &flat[1..] {
        let v = sub_q(p, f0);
        let mut m = dirs.clone();
        m.push(v.clone());
        if rank(&m) > dirs.len() {
            dirs.push(v);
        }
    }
    // Normal of the facet plane: null vector of (dirs + apex - f0).
    let mut span = dirs.clone();
    span.push(sub_q(apex, f0));
    let normal = crate::math::linalg::nullspace(&span).into_iter().next();
    let Some(normal) = normal else { return false };
    let side = |p: &QVec| {
        let mut m = dirs.clone();
        m.push(sub_q(p, f0));
        m.push(normal.clone());
        if m.len() != s {
            return 0;
        }
        crate::math::linalg::det(&m).signum()
    };
    let sa = side(apex);
    pts.iter().all(|p| {
        let sp = side(p);
        sp == 0 || sp == sa
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cube_split_into_tetrahedra() {
        let q = |n| Q::int(n);
        let cube = Polytope::unit_cube(&[q(0), q(0), q(0)]);
        assert_eq!(cube.vertices.len(), 8);
        assert_eq!(cube.facets.len(), 6);
        assert_eq!(cube.volume(), q(1));
        let (a, b) = cube.split(&[q(1), q(-1), q(0)], &q(0)).unwrap();
        assert_eq!(a.vertices.len(), 6);
        assert_eq!(a.volume(), Q::frac(1, 2));
        assert_eq!(&a.volume() + &b.volume(), q(1));
        let (c, _) = a.split(&[q(1), q(1), q(1)], &q(1)).unwrap();
        assert!(c.is_simplex());
        assert_eq!(c.volume(), Q::frac(1, 12));
        assert!(cube.split(&[q(1), q(0), q(0)], &q(1)).is_none());
    }

    #[test]
    fn square_volume() {
        let q = |n| Q::int(n);
        let sq = Polytope::unit_cube(&[q(0), q(0)]);
        let (a, b) = sq.split(&[q(1), q(1)], &q(1)).unwrap();
        assert_eq!(a.volume(), Q::frac(1, 2));
        assert_eq!(b.volume(), Q::frac(1, 2));
    }
}
