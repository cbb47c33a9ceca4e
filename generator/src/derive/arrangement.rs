//! Knot planes of the shift-invariant space and the evaluation cells: every
//! cube class cut by the knot planes that cross it.

use crate::derive::spline::SplineFacts;
use crate::math::exact::Q;
use crate::math::linalg::{dot_i, dot_iq, sub_i, to_q, IVec, QVec};
use crate::math::polytope::Polytope;
use crate::spec::lattice::Lattice;
use serde::Serialize;
use std::collections::HashMap;

/// The planes n . x in offset + period Z.
#[derive(Clone, Debug, PartialEq, Eq, Serialize)]
pub struct KnotFamily {
    /// Primitive integer normal n of the planes.
    pub normal: IVec,
    /// alpha_n = -n.c mod g_n, in [0, g_n).
    pub offset: Q,
    /// g_n = gcd of n . (columns of G).
    pub period: i64,
}

impl KnotFamily {
    /// The family of knot planes with this normal, shifted by the centre and
    /// repeating with the lattice.
    pub fn new(normal: &[i64], lattice: &Lattice, center: &[Q]) -> KnotFamily {
        let period = lattice.generators.iter().fold(0, |g, col| crate::math::exact::gcd(g, dot_i(normal, col)));
        let g = Q::int(period);
        let a = -dot_iq(normal, center);
        let offset = &a - &(&(&a / &g).floor() * &g);
        KnotFamily { normal: normal.to_vec(), offset, period }
    }

    /// Plane values n.x = offset + k period strictly between lo and hi.
    pub fn values_between(&self, lo: &Q, hi: &Q) -> Vec<Q> {
        let g = Q::int(self.period);
        let mut k = ((lo - &self.offset) / &g).floor();
        let mut out = Vec::new();
        loop {
            let v = &self.offset + &(&k * &g);
            if &v >= hi {
                break;
            }
            if &v > lo {
                out.push(v);
            }
            k += Q::one();
        }
        out
    }

    /// Is n . x = v one of these planes?
    pub fn contains_value(&self, v: &Q) -> bool {
        ((v - &self.offset) / &Q::int(self.period)).is_integer()
    }
}

/// One evaluation cell: a convex polytope inside the unit cube o + z + `[0,1]^s`
/// of a cube-class representative z.
#[derive(Clone, Debug)]
pub struct Cell {
    /// Index into `Arrangement::classes`.
    pub class: usize,
    /// The cell itself, in global coordinates.
    pub polytope: Polytope,
    /// A point strictly inside (the vertex centroid).
    pub interior: QVec,
}

/// The evaluation cells: every cube class cut by the knot planes that cross it.
#[derive(Clone, Debug)]
pub struct Arrangement {
    /// The knot-plane families, one per primitive normal.
    pub families: Vec<KnotFamily>,
    /// o: grid planes are x_i in o_i + Z.
    pub grid_offset: QVec,
    /// Integer lower corners z of the representative cubes (one per class of Z^s / L).
    pub classes: Vec<IVec>,
    /// Cells, sorted by class then vertices.
    pub cells: Vec<Cell>,
    /// Regions of the knot-plane arrangement alone per fundamental domain of L.
    pub pieces_per_fundamental_domain: usize,
}

impl Arrangement {
    /// Builds the frame and cuts its cells (see [`Frame`] to count them first).
    pub fn new(facts: &SplineFacts, lattice: &Lattice) -> Arrangement {
        Arrangement::from_frame(Frame::new(facts, lattice), lattice)
    }

    /// The cells of every cube class, cut from the frame's planes.
    pub fn from_frame(frame: Frame, lattice: &Lattice) -> Arrangement {
        let mut cells = Vec::new();
        for ci in 0..frame.classes.len() {
            let lo = frame.cube_lower_corner(ci);
            let planes: Vec<(QVec, Q)> = frame.crossing_planes(ci).into_iter().map(|(n, v)| (to_q(&n), v)).collect();
            let mut parts = Vec::new();
            cut_recursively(Polytope::unit_cube(&lo), &planes, &mut parts);
            let mut class_cells: Vec<Cell> =
                parts.into_iter().map(|p| Cell { class: ci, interior: p.centroid(), polytope: p }).collect();
            class_cells.sort_by(|a, b| a.polytope.vertices.cmp(&b.polytope.vertices));
            cells.extend(class_cells);
        }
        let Frame { families, grid_offset, classes } = frame;
        let mut arr = Arrangement { families, grid_offset, classes, cells, pieces_per_fundamental_domain: 0 };
        arr.pieces_per_fundamental_domain = arr.count_pieces(lattice);
        arr
    }

    /// The cube's integer lower corner z for cell i (the cube is o + z + `[0,1]^s`).
    pub fn corner(&self, cell: usize) -> &IVec {
        &self.classes[self.cells[cell].class]
    }

    /// Index of the class representative for an arbitrary cube corner z, and
    /// the lattice vector l with z = rep + l.
    pub fn locate_cube(&self, lattice: &Lattice, z: &[i64]) -> (usize, IVec) {
        let r = lattice.reduce(z);
        let ci = self.classes.iter().position(|c| lattice.reduce(c) == r).expect("class representatives are complete");
        (ci, sub_i(z, &self.classes[ci]))
    }

    /// Merges cells across grid faces that are not knot planes (mod L) and
    /// counts the resulting regions: the true polynomial pieces.
    fn count_pieces(&self, lattice: &Lattice) -> usize {
        let s = self.grid_offset.len();
        let mut parent: Vec<usize> = (0..self.cells.len()).collect();
        fn find(p: &mut [usize], i: usize) -> usize {
            let mut r = i;
            while p[r] != r {
                r = p[r];
            }
            p[i] = r;
            r
        }
        // Every cell face on its cube's boundary, by (class, sorted face vertices).
        let mut faces: HashMap<(usize, Vec<QVec>), usize> = HashMap::new();
        for (i, cell) in self.cells.iter().enumerate() {
            let z = &self.classes[cell.class];
            for axis in 0..s {
                for upper in [false, true] {
                    let plane = &(&self.grid_offset[axis] + &Q::int(z[axis])) + &Q::int(upper as i64);
                    let face: Vec<QVec> = cell.polytope.vertices.iter().filter(|v| v[axis] == plane).cloned().collect();
                    if face.len() >= s {
                        faces.insert((cell.class, face), i);
                    }
                }
            }
        }
        let facet_key = |verts: &[QVec]| {
            let mut v = verts.to_vec();
            v.sort();
            v
        };
        for (i, cell) in self.cells.iter().enumerate() {
            let z = &self.classes[cell.class];
            for axis in 0..s {
                for upper in [false, true] {
                    let plane = &(&self.grid_offset[axis] + &Q::int(z[axis])) + &Q::int(upper as i64);
                    let face: Vec<QVec> = cell.polytope.vertices.iter().filter(|v| v[axis] == plane).cloned().collect();
                    if face.len() < s {
                        continue;
                    }
                    let d: Vec<QVec> = face[1..].iter().map(|v| crate::math::linalg::sub_q(v, &face[0])).collect();
                    if crate::math::linalg::rank(&d) < s - 1 {
                        continue;
                    }
                    let mut e = vec![0; s];
                    e[axis] = 1;
                    if self.families.iter().any(|f| f.normal == e && f.contains_value(&plane)) {
                        continue; // a knot plane separates different pieces
                    }
                    // Neighbour cube across this face, moved to its representative.
                    let mut nz = z.clone();
                    nz[axis] += if upper { 1 } else { -1 };
                    let (nci, l) = self.locate_cube(lattice, &nz);
                    let shift = to_q(&l);
                    let key =
                        facet_key(&face.iter().map(|v| crate::math::linalg::sub_q(v, &shift)).collect::<Vec<_>>());
                    let neighbour = faces.get(&(nci, key)).map(|&j| (j, ()));
                    if let Some((j, _)) = neighbour {
                        let (a, b) = (find(&mut parent, i), find(&mut parent, j));
                        parent[a.max(b)] = a.min(b);
                    }
                }
            }
        }
        (0..self.cells.len()).filter(|&i| find(&mut parent, i) == i).count()
    }
}

/// What the arrangement is built from: the knot-plane families, the grid
/// offset and the cube classes. Cheap; [`Frame::count_cells`] counts the
/// cells from it without cutting.
#[derive(Clone, Debug)]
pub struct Frame {
    /// The knot-plane families, one per primitive normal.
    pub families: Vec<KnotFamily>,
    /// o: grid planes are x_i in o_i + Z.
    pub grid_offset: QVec,
    /// Integer lower corners z of the representative cubes (one per class of Z^s / L).
    pub classes: Vec<IVec>,
}

impl Frame {
    /// The knot families, grid offset and cube classes of a spline on a lattice.
    pub fn new(facts: &SplineFacts, lattice: &Lattice) -> Frame {
        let s = facts.dim;
        let families: Vec<KnotFamily> =
            facts.normals.iter().map(|n| KnotFamily::new(n, lattice, &facts.center)).collect();
        let grid_offset: QVec = (0..s)
            .map(|i| {
                let mut e = vec![0; s];
                e[i] = 1;
                match families.iter().find(|f| f.normal == e) {
                    Some(f) => &f.offset - &f.offset.floor(),
                    None => Q::zero(),
                }
            })
            .collect();
        Frame { families, grid_offset, classes: lattice.classes() }
    }

    /// o + z for the representative z of class `ci`.
    pub fn cube_lower_corner(&self, ci: usize) -> QVec {
        self.grid_offset.iter().zip(&self.classes[ci]).map(|(o, z)| o + &Q::int(*z)).collect()
    }

    /// The knot planes n . x = v that cross the open cube of class `ci`.
    pub fn crossing_planes(&self, ci: usize) -> Vec<(IVec, Q)> {
        let lo = self.cube_lower_corner(ci);
        let mut planes = Vec::new();
        for f in &self.families {
            let (lo_v, hi_v) = cube_range(&f.normal, &lo);
            for v in f.values_between(&lo_v, &hi_v) {
                planes.push((f.normal.clone(), v));
            }
        }
        planes
    }

    /// The number of cells of every class, exactly, without cutting (see
    /// [`crate::derive::cell_count`]).
    pub fn count_cells(&self) -> usize {
        match self.count_cells_within(usize::MAX) {
            Ok(n) | Err(n) => n,
        }
    }

    /// [`Frame::count_cells`], or `Err(lower bound)` as soon as a lower
    /// bound exceeds `budget` (a refusal then costs a fraction of the count).
    ///
    /// # Errors
    ///
    /// `Err(lower bound)` when the count exceeds `budget` (not a crate error).
    pub fn count_cells_within(&self, budget: usize) -> Result<usize, usize> {
        let mut total = 0usize;
        for ci in 0..self.classes.len() {
            let left = budget.saturating_sub(total);
            match crate::derive::cell_count::count_regions_within(
                &self.crossing_planes(ci),
                &self.cube_lower_corner(ci),
                left,
            ) {
                Ok(n) => total += n,
                Err(lower) => return Err(total + lower),
            }
            if total > budget {
                return Err(total);
            }
        }
        Ok(total)
    }
}

/// Cuts `p` by every plane that crosses it. Each level keeps only the planes
/// that still cut the part and splits by the middle one, so the work follows
/// the size of the final arrangement rather than planes x parts.
fn cut_recursively(p: Polytope, planes: &[(QVec, Q)], out: &mut Vec<Polytope>) {
    let relevant: Vec<&(QVec, Q)> = planes.iter().filter(|(n, a)| p.is_cut_by(n, a)).collect();
    if relevant.is_empty() {
        out.push(p);
        return;
    }
    let mid = relevant.len() / 2;
    let (n, a) = relevant[mid];
    let (lo, hi) = p.split(n, a).expect(
        "the plane is in `relevant` because is_cut_by found vertices on both sides, the condition split checks",
    );
    let rest: Vec<(QVec, Q)> =
        relevant.iter().enumerate().filter(|(i, _)| *i != mid).map(|(_, x)| (*x).clone()).collect();
    cut_recursively(lo, &rest, out);
    cut_recursively(hi, &rest, out);
}

/// min and max of n.x over the unit cube lo + `[0,1]^s`.
fn cube_range(n: &[i64], lo: &[Q]) -> (Q, Q) {
    let base = dot_iq(n, lo);
    let neg: i64 = n.iter().filter(|&&x| x < 0).sum();
    let pos: i64 = n.iter().filter(|&&x| x > 0).sum();
    (&base + &Q::int(neg), &base + &Q::int(pos))
}
