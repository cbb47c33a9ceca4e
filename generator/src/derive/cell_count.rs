//! The number of cells of a cube before cutting it: the regions of an
//! arrangement of planes inside an open convex set are counted by the Möbius
//! function of its intersection poset (Zaslavsky; every flat meeting the set
//! meets it in a convex, contractible piece):
//!
//! ```text
//! 2D: regions = 1 + m + sum over points p of (n_p - 1)
//! 3D: regions = 1 + m + sum over lines L of (k_L - 1)
//!             + sum over points p of (1 - n_p + sum over lines L through p of (k_L - 1))
//! ```
//!
//! with m planes (lines in 2D) crossing the open cube, k_L the planes that
//! contain line L, n_p the planes through point p, and only flats that meet
//! the open cube counted. It is exact for any degeneracy and costs
//! O(lines x planes) rational operations instead of building polytopes, so
//! [`super::Derivation::new`] knows the size of the answer before paying for
//! it (and refuses at once when it exceeds a cap).

use crate::math::exact::Q;
use crate::math::linalg::{dot_iq, primitive, IVec, QVec};
use std::collections::{BTreeSet, HashMap};

/// One knot plane n . x = v.
pub type Plane = (IVec, Q);

/// Regions of the open unit cube `lo + (0,1)^s` cut by `planes` (each of
/// which crosses the open cube): closed forms in 2D and 3D, the general
/// Möbius sum ([`count_any_dimension`]) beyond.
pub fn count_regions(planes: &[Plane], lo: &[Q]) -> usize {
    match count_regions_within(planes, lo, usize::MAX) {
        Ok(n) | Err(n) => n,
    }
}

/// [`count_regions`], but `Err(lower bound)` as soon as a lower bound
/// exceeds `budget`: every term of the count is non-negative, so 1 + m and
/// then 1 + m + the line terms bound it from below before the costly point
/// terms (O(lines x planes)) are computed.
///
/// # Errors
///
/// `Err(lower bound)` when the count exceeds `budget` (not a crate error).
///
pub fn count_regions_within(planes: &[Plane], lo: &[Q], budget: usize) -> Result<usize, usize> {
    if 1 + planes.len() > budget {
        return Err(1 + planes.len());
    }
    match lo.len() {
        2 => Ok(count_2d(planes, lo)),
        3 => count_3d(planes, lo, budget),
        _ => count_any_dimension_within(planes, lo, budget),
    }
}

/// Regions of the open cube `lo + (0,1)^s` in any dimension, by the same
/// theorem as the 2D and 3D formulas written out generally: the flats
/// (non-empty intersections of the planes that meet the open cube) are
/// enumerated codimension by codimension, each with the flats that cover
/// it, the Möbius function mu(V, F) follows from mu(F) = -sum of mu over
/// the flats strictly above F, and regions = sum over flats of |mu| =
/// sum of (-1)^codim mu. Exact (rationals); whether a flat meets the open
/// cube is decided by Fourier-Motzkin elimination of strict inequalities.
/// Used for 4D; the 2D and 3D closed forms are checked against it.
pub fn count_any_dimension(planes: &[Plane], lo: &[Q]) -> usize {
    match count_any_dimension_within(planes, lo, usize::MAX) {
        Ok(n) | Err(n) => n,
    }
}

/// [`count_any_dimension`], but `Err(lower bound)` once the flats found
/// exceed `budget`: every flat F meeting the cube has (-1)^codim mu(F) >= 1,
/// so regions >= 1 + flats, and a refusal costs O(budget x planes).
///
/// # Errors
///
/// `Err(lower bound)` when the count exceeds `budget` (not a crate error).
pub fn count_any_dimension_within(planes: &[Plane], lo: &[Q], budget: usize) -> Result<usize, usize> {
    let s = lo.len();
    // Flats as reduced row echelon forms of [n | v]; index 0 is the whole space.
    let rows_of = |i: usize| -> QVec {
        let (n, v) = &planes[i];
        n.iter().map(|&x| Q::int(x)).chain(std::iter::once(v.clone())).collect()
    };
    let mut keys: HashMap<Vec<QVec>, usize> = HashMap::new();
    let mut flats: Vec<Vec<QVec>> = vec![vec![]];
    let mut codim: Vec<usize> = vec![0];
    let mut parents: Vec<Vec<usize>> = vec![vec![]];
    let mut level: Vec<usize> = vec![0];
    for k in 0..s {
        let mut next: Vec<usize> = Vec::new();
        for &f in &level {
            for j in 0..planes.len() {
                let mut rows = flats[f].clone();
                rows.push(rows_of(j));
                let Some(r) = rref_affine(rows, s) else { continue }; // parallel: empty
                if r.len() != k + 1 {
                    continue; // the plane contains the flat
                }
                if let Some(&g) = keys.get(&r) {
                    if !parents[g].contains(&f) {
                        parents[g].push(f);
                    }
                    continue;
                }
                // Codimension 1: the planes cross the open cube (precondition).
                if k > 0 && !flat_meets_open_cube(&r, lo) {
                    continue;
                }
                let g = flats.len();
                if g >= budget {
                    return Err(g + 1);
                }
                keys.insert(r.clone(), g);
                flats.push(r);
                codim.push(k + 1);
                parents.push(vec![f]);
                next.push(g);
            }
        }
        level = next;
    }
    // mu over the flats in order of codimension (parents come first).
    let mut mu: Vec<i64> = vec![0; flats.len()];
    mu[0] = 1;
    let mut regions: i64 = 1;
    let mut seen: Vec<usize> = vec![usize::MAX; flats.len()];
    for g in 1..flats.len() {
        let mut stack: Vec<usize> = parents[g].clone();
        let mut sum = 0i64;
        for &p in &stack {
            seen[p] = g;
        }
        while let Some(p) = stack.pop() {
            sum += mu[p];
            for &q in &parents[p] {
                if seen[q] != g {
                    seen[q] = g;
                    stack.push(q);
                }
            }
        }
        mu[g] = -sum;
        regions += if codim[g].is_multiple_of(2) { mu[g] } else { -mu[g] };
    }
    let regions = regions as usize;
    if regions > budget {
        Err(regions)
    } else {
        Ok(regions)
    }
}

/// Reduced row echelon form of an affine system [A | b] (s unknowns), zero
/// rows dropped; None when it is inconsistent (0 = 1).
fn rref_affine(mut m: Vec<QVec>, s: usize) -> Option<Vec<QVec>> {
    let mut r = 0;
    for c in 0..=s {
        let Some(p) = (r..m.len()).find(|&i| !m[i][c].is_zero()) else { continue };
        if c == s {
            return None;
        }
        m.swap(r, p);
        let inv = m[r][c].recip();
        m[r] = m[r].iter().map(|x| x * &inv).collect();
        for i in 0..m.len() {
            if i != r && !m[i][c].is_zero() {
                let f = m[i][c].clone();
                let pr = m[r].clone();
                for (x, y) in m[i].iter_mut().zip(&pr) {
                    *x -= &(&f * y);
                }
            }
        }
        r += 1;
    }
    m.truncate(r);
    Some(m)
}

/// Does the affine flat (RREF rows [A | b]) meet the open cube lo + (0,1)^s?
/// The pivot unknowns are written in the free ones, the 2s strict bounds
/// become strict inequalities a . y < c in the free unknowns, and
/// Fourier-Motzkin eliminates them (strict stays strict).
fn flat_meets_open_cube(rows: &[QVec], lo: &[Q]) -> bool {
    let s = lo.len();
    let pivots: Vec<usize> =
        rows.iter().map(|r| r.iter().position(|x| !x.is_zero()).expect("RREF rows are non-zero")).collect();
    let free: Vec<usize> = (0..s).filter(|c| !pivots.contains(c)).collect();
    // x_i = const + coef . y
    let mut ineqs: Vec<(QVec, Q)> = Vec::new();
    for i in 0..s {
        let (coef, cst): (QVec, Q) = match pivots.iter().position(|&p| p == i) {
            Some(r) => (free.iter().map(|&f| -rows[r][f].clone()).collect(), rows[r][s].clone()),
            None => (free.iter().map(|&f| if f == i { Q::one() } else { Q::zero() }).collect(), Q::zero()),
        };
        // lo < cst + coef.y  <=>  -coef.y < cst - lo
        ineqs.push((coef.iter().map(|x| -x.clone()).collect(), &cst - &lo[i]));
        // cst + coef.y < lo + 1  <=>  coef.y < lo + 1 - cst
        ineqs.push((coef, &(&lo[i] + &Q::one()) - &cst));
    }
    for k in 0..free.len() {
        let (mut pos, mut neg, mut rest) = (Vec::new(), Vec::new(), Vec::new());
        for (a, c) in ineqs {
            match a[k].signum() {
                1 => pos.push((a, c)),
                -1 => neg.push((a, c)),
                _ => rest.push((a, c)),
            }
        }
        for (ap, cp) in &pos {
            for (an, cn) in &neg {
                let (wp, wn) = (-an[k].clone(), ap[k].clone());
                let a: QVec = ap.iter().zip(an).map(|(x, y)| &(x * &wp) + &(y * &wn)).collect();
                rest.push((a, &(cp * &wp) + &(cn * &wn)));
            }
        }
        rest.sort();
        rest.dedup();
        ineqs = rest;
    }
    ineqs.iter().all(|(_, c)| c.is_positive())
}

fn inside(p: &[Q], lo: &[Q]) -> bool {
    p.iter().zip(lo).all(|(x, l)| x > l && *x < l + &Q::one())
}

/// Intersection of two lines (2D) or three planes (3D) by Cramer's rule.
fn meet(planes: &[&Plane]) -> Option<QVec> {
    let s = planes.len();
    let m: Vec<Vec<Q>> = planes.iter().map(|(n, _)| n.iter().map(|&x| Q::int(x)).collect()).collect();
    let b: Vec<Q> = planes.iter().map(|(_, v)| v.clone()).collect();
    crate::math::linalg::solve(&m, &b).filter(|x| x.len() == s)
}

fn count_2d(lines: &[Plane], lo: &[Q]) -> usize {
    let mut points: HashMap<QVec, BTreeSet<usize>> = HashMap::new();
    for i in 0..lines.len() {
        for j in i + 1..lines.len() {
            if let Some(p) = meet(&[&lines[i], &lines[j]]) {
                if inside(&p, lo) {
                    let e = points.entry(p).or_default();
                    e.insert(i);
                    e.insert(j);
                }
            }
        }
    }
    1 + lines.len() + points.values().map(|s| s.len() - 1).sum::<usize>()
}

fn cross(a: &[i64], b: &[i64]) -> IVec {
    vec![a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
}

/// A line as its primitive direction (first non-zero entry positive) and
/// its point on the coordinate plane x_a = 0 of the first axis a it crosses.
#[derive(Clone, PartialEq, Eq, Hash)]
struct LineKey {
    direction: IVec,
    point: QVec,
}

fn count_3d(planes: &[Plane], lo: &[Q], budget: usize) -> Result<usize, usize> {
    let m = planes.len();
    // Every line where two planes meet, with the planes that contain it.
    let mut lines: HashMap<LineKey, BTreeSet<usize>> = HashMap::new();
    for i in 0..m {
        for j in i + 1..m {
            let d = cross(&planes[i].0, &planes[j].0);
            let Some(mut direction) = primitive(&d) else { continue }; // parallel planes
            if direction.iter().find(|&&x| x != 0).is_some_and(|&x| x < 0) {
                direction.iter_mut().for_each(|x| *x = -*x);
            }
            let axis =
                direction.iter().position(|&x| x != 0).expect("primitive returned Some, so the direction is non-zero");
            let mut e = vec![0; 3];
            e[axis] = 1;
            let point = meet(&[&planes[i], &planes[j], &(e, Q::zero())]).expect(
                "the normals and e_axis are independent (det = direction[axis] != 0): the planes meet in a point",
            );
            lines.entry(LineKey { direction, point }).or_default().extend([i, j]);
        }
    }
    let lines: Vec<(LineKey, BTreeSet<usize>)> =
        lines.into_iter().filter(|(l, _)| line_meets_open_cube(l, lo)).collect();
    let line_terms: usize = lines.iter().map(|(_, on)| on.len() - 1).sum();
    if 1 + m + line_terms > budget {
        return Err(1 + m + line_terms);
    }
    // Points: each line against every plane that crosses it.
    let mut points: HashMap<QVec, (BTreeSet<usize>, BTreeSet<usize>)> = HashMap::new();
    for (li, (line, on)) in lines.iter().enumerate() {
        for (k, (n, v)) in planes.iter().enumerate() {
            let nd: i64 = n.iter().zip(&line.direction).map(|(a, b)| a * b).sum();
            if nd == 0 {
                continue; // parallel to (or containing) the line
            }
            let t = &(v - &dot_iq(n, &line.point)) / &Q::int(nd);
            let p: QVec = line.point.iter().zip(&line.direction).map(|(x, &d)| x + &(&t * &Q::int(d))).collect();
            if !inside(&p, lo) {
                continue;
            }
            let (through, crossing) = points.entry(p).or_default();
            through.extend(on.iter().copied());
            through.insert(k);
            crossing.insert(li);
        }
    }
    let point_terms: i64 = points
        .values()
        .map(|(through, crossing)| {
            1 - through.len() as i64 + crossing.iter().map(|&l| lines[l].1.len() as i64 - 1).sum::<i64>()
        })
        .sum();
    Ok((1 + m as i64 + line_terms as i64 + point_terms) as usize)
}

/// Does x0 + t d meet the open cube lo + (0,1)^3?
fn line_meets_open_cube(line: &LineKey, lo: &[Q]) -> bool {
    let mut t_lo: Option<Q> = None;
    let mut t_hi: Option<Q> = None;
    for i in 0..3 {
        let (x, d) = (&line.point[i], line.direction[i]);
        let (a, b) = (lo[i].clone(), &lo[i] + &Q::one());
        if d == 0 {
            if !(x > &a && x < &b) {
                return false;
            }
            continue;
        }
        let (mut t0, mut t1) = (&(&a - x) / &Q::int(d), &(&b - x) / &Q::int(d));
        if d < 0 {
            std::mem::swap(&mut t0, &mut t1);
        }
        t_lo = Some(t_lo.map_or(t0.clone(), |t: Q| t.max(t0)));
        t_hi = Some(t_hi.map_or(t1.clone(), |t: Q| t.min(t1)));
    }
    match (t_lo, t_hi) {
        (Some(a), Some(b)) => a < b,
        _ => true,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn plane(n: &[i64], v: Q) -> Plane {
        (n.to_vec(), v)
    }

    #[test]
    fn generic_and_degenerate_arrangements() {
        let lo = vec![Q::zero(); 3];
        let h = Q::frac(1, 2);
        // Three coordinate mid-planes: 8 octants.
        let three = [plane(&[1, 0, 0], h.clone()), plane(&[0, 1, 0], h.clone()), plane(&[0, 0, 1], h.clone())];
        assert_eq!(count_regions(&three, &lo), 8);
        // Four planes through the centre's line x = y (the diagonal x + y = 1 too): a pencil and one more.
        let pencil = [
            plane(&[1, -1, 0], Q::zero()),
            plane(&[1, 1, 0], Q::one()),
            plane(&[1, 0, 0], h.clone()),
            plane(&[0, 0, 1], h.clone()),
        ];
        // The first three share the line x = y = 1/2 (k = 3): 6 wedges, cut by z = 1/2: 12.
        assert_eq!(count_regions(&pencil, &lo), 12);
        // The tetrahedral split of a cube by x=y, y=z, x=z: 6 simplices.
        let kuhn = [plane(&[1, -1, 0], Q::zero()), plane(&[0, 1, -1], Q::zero()), plane(&[1, 0, -1], Q::zero())];
        assert_eq!(count_regions(&kuhn, &lo), 6);
        // 2D: the square's two diagonals: 4 triangles.
        let lo2 = vec![Q::zero(); 2];
        assert_eq!(count_regions(&[plane(&[1, -1], Q::zero()), plane(&[1, 1], Q::one())], &lo2), 4);
        // The general count agrees on each of these.
        assert_eq!(count_any_dimension(&three, &lo), 8);
        assert_eq!(count_any_dimension(&pencil, &lo), 12);
        assert_eq!(count_any_dimension(&kuhn, &lo), 6);
        // 4D: the Kuhn split of the 4-cube by x_i = x_j: 4! = 24 simplices;
        // the four mid-planes: 16 orthants; a plane missing the cube adds nothing.
        let lo4 = vec![Q::zero(); 4];
        let mut kuhn4 = Vec::new();
        for i in 0..4 {
            for j in i + 1..4 {
                let mut n = vec![0; 4];
                n[i] = 1;
                n[j] = -1;
                kuhn4.push(plane(&n, Q::zero()));
            }
        }
        assert_eq!(count_regions(&kuhn4, &lo4), 24);
        let mids: Vec<Plane> = (0..4)
            .map(|i| {
                let mut n = vec![0; 4];
                n[i] = 1;
                plane(&n, h.clone())
            })
            .collect();
        assert_eq!(count_regions(&mids, &lo4), 16);
        let mut both = kuhn4.clone();
        both.extend(mids);
        // x_i = x_j and x_i = 1/2: each of the 24 simplices 0 < x_p1 < ... < x_p4 < 1 is cut
        // by the mid-planes into the 5 positions of 1/2 among the sorted coordinates.
        assert_eq!(count_regions(&both, &lo4), 120);
    }

    /// The closed 2D/3D formulas and the general count agree on the catalog
    /// and on random specs (two independent counts of the same regions).
    #[test]
    fn general_count_agrees_with_the_closed_forms() {
        use crate::derive::arrangement::Frame;
        use crate::derive::spline::SplineFacts;
        let mut filters = crate::spec::catalog::all().unwrap();
        filters.extend(crate::spec::random::benchmark_specs(5, 30));
        for f in &filters {
            let facts = SplineFacts::new(f);
            let frame = Frame::new(&facts, &f.lattice);
            for ci in 0..frame.classes.len() {
                let planes = frame.crossing_planes(ci);
                if planes.len() > 40 {
                    continue;
                }
                let lo = frame.cube_lower_corner(ci);
                assert_eq!(count_regions(&planes, &lo), count_any_dimension(&planes, &lo), "{}", f.name);
            }
        }
    }

    /// The count equals the number of cells that cutting produces, on the
    /// catalog and on seeded random specs (degenerate pencils included).
    #[test]
    fn counting_agrees_with_cutting() {
        use crate::derive::arrangement::{Arrangement, Frame};
        use crate::derive::spline::SplineFacts;
        let mut filters = crate::spec::catalog::all().unwrap();
        filters.extend(crate::spec::random::benchmark_specs(5, 60));
        let mut compared = 0;
        for f in &filters {
            let facts = SplineFacts::new(f);
            let frame = Frame::new(&facts, &f.lattice);
            let counted = frame.count_cells();
            if counted > 3000 {
                continue; // keep the test quick; the count is checked on the rest
            }
            assert_eq!(counted, Arrangement::new(&facts, &f.lattice).cells.len(), "{} {:?}", f.name, f.directions);
            compared += 1;
        }
        assert!(compared > 50, "{compared} filters compared");
    }
}
