//! The tetrahedral meshes of projected tetrahedra (Mattausch et al. 2003,
//! §4): on BCC the Delaunay tetrahedra, grouped into traversal complexes of
//! 12 (three octahedra spanned from a primary sample to its primary
//! neighbours in +x, +y, +z, four tetrahedra each, §4.1); on CC the six
//! Kuhn tetrahedra of each cube (around its main diagonal). Every complex is
//! a translate of one fixed set of tetrahedron *types*, so the per-type
//! quantities (vertex offsets, the inverse edge matrix that gives the
//! gradient, the depth order inside a complex) are computed once, as the
//! paper does with its table of 12 transformation matrices.

use boxforge::spec::lattice::Lattice;

/// Which mesh: the lattice the samples lie on.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Grid {
    /// Body-centred cubic, embedded in Z^3 as the points with coordinates of
    /// one parity (primary grid: all even; secondary: all odd).
    Bcc,
    /// Cartesian (every integer point).
    Cc,
}

impl Grid {
    /// The mesh for a data lattice, or None for one without a tetrahedral mesh here.
    pub fn of(lattice: &Lattice) -> Option<Grid> {
        match lattice.name.as_str() {
            "bcc" => Some(Grid::Bcc),
            "cc" => Some(Grid::Cc),
            _ => None,
        }
    }

    /// Spacing of the complexes' base points along each axis.
    pub fn spacing(self) -> i64 {
        match self {
            Grid::Bcc => 2,
            Grid::Cc => 1,
        }
    }

    /// The box spline whose translates are the barycentric interpolant on
    /// this mesh (so the ray caster shows the function PT draws): on BCC the
    /// catalog's `bcc_linear`; on CC, for the Kuhn tetrahedra around each
    /// cube's main diagonal, the spline with directions e1, e2, e3, (1, 1, 1).
    pub fn linear_filter(self) -> boxforge::Filter {
        let text = match self {
            Grid::Bcc => boxforge::spec::catalog::source("bcc_linear").expect("bcc_linear is in the catalog").to_string(),
            Grid::Cc => "name = \"cc_kuhn_linear\"\ndescription = \"barycentric interpolation on the Kuhn tetrahedra of the cubes\"\nlattice = \"cc\"\ndirections = [[1,0,0],[0,1,0],[0,0,1],[1,1,1]]\n".to_string(),
        };
        boxforge::Filter::from_toml(&text, "pt::tets::Grid::linear_filter").expect("a valid spec")
    }

    /// The vertex offsets of every tetrahedron type, from the complex's base point.
    pub fn types(self) -> Vec<[[i64; 3]; 4]> {
        match self {
            Grid::Bcc => bcc_types(),
            Grid::Cc => cc_types(),
        }
    }
}

/// The 12 BCC types: for each axis a, the octahedron between p and p + 2 e_a
/// with the four secondary samples p + e_a ± e_b ± e_c, cut into four
/// tetrahedra around its primary edge (two primary and two adjacent
/// secondary samples each: the Delaunay tetrahedra, figure 4).
fn bcc_types() -> Vec<[[i64; 3]; 4]> {
    let mut out = Vec::new();
    for a in 0..3 {
        let (b, c) = ((a + 1) % 3, (a + 2) % 3);
        let ring = [(1, 1), (-1, 1), (-1, -1), (1, -1)];
        let q = |(sb, sc): (i64, i64)| {
            let mut v = [0i64; 3];
            v[a] = 1;
            v[b] = sb;
            v[c] = sc;
            v
        };
        let mut p1 = [0i64; 3];
        p1[a] = 2;
        for k in 0..4 {
            out.push([[0, 0, 0], p1, q(ring[k]), q(ring[(k + 1) % 4])]);
        }
    }
    out
}

/// The 6 Kuhn types of the unit cube: p, p + e_i, p + e_i + e_j, p + (1,1,1)
/// for each permutation (i, j, k); translates share faces, so they tile.
fn cc_types() -> Vec<[[i64; 3]; 4]> {
    let perms = [[0, 1, 2], [0, 2, 1], [1, 0, 2], [1, 2, 0], [2, 0, 1], [2, 1, 0]];
    perms
        .iter()
        .map(|&[i, j, _]| {
            let mut v1 = [0i64; 3];
            v1[i] = 1;
            let mut v2 = v1;
            v2[j] = 1;
            [[0, 0, 0], v1, v2, [1, 1, 1]]
        })
        .collect()
}

/// The inverse of the edge matrix E (rows v_k - v_0, k = 1..3) of a type:
/// the gradient of the linear interpolant is E^-1 (s_1 - s_0, s_2 - s_0, s_3 - s_0).
pub fn inverse_edges(t: &[[i64; 3]; 4]) -> [[f64; 3]; 3] {
    let e: [[f64; 3]; 3] = [1, 2, 3].map(|k| [0, 1, 2].map(|i| (t[k][i] - t[0][i]) as f64));
    let det = e[0][0] * (e[1][1] * e[2][2] - e[1][2] * e[2][1]) - e[0][1] * (e[1][0] * e[2][2] - e[1][2] * e[2][0])
        + e[0][2] * (e[1][0] * e[2][1] - e[1][1] * e[2][0]);
    assert!(det.abs() > 0.5, "a tetrahedron type has volume");
    let cof = |r: usize, c: usize| {
        let (r1, r2) = ((r + 1) % 3, (r + 2) % 3);
        let (c1, c2) = ((c + 1) % 3, (c + 2) % 3);
        e[r1][c1] * e[r2][c2] - e[r1][c2] * e[r2][c1]
    };
    // inverse = adjugate / det, adjugate[i][j] = cofactor[j][i].
    [0, 1, 2].map(|i| [0, 1, 2].map(|j| cof(j, i) / det))
}

/// The back-to-front order of the types inside a complex for view direction
/// `forward` (pointing away from the eye): by decreasing depth of the
/// centroid. Inside one octahedron (a fan of congruent wedges around an
/// axis, mirror images across the planes through it) and inside one cube
/// (the Kuhn fan around the diagonal) this respects every shared face.
pub fn type_order(types: &[[[i64; 3]; 4]], forward: [f64; 3]) -> Vec<usize> {
    let depth = |t: &[[i64; 3]; 4]| -> f64 {
        (0..3).map(|i| forward[i] * t.iter().map(|v| v[i] as f64).sum::<f64>() / 4.0).sum()
    };
    let mut order: Vec<usize> = (0..types.len()).collect();
    order.sort_by(|&a, &b| depth(&types[b]).total_cmp(&depth(&types[a])).then(a.cmp(&b)));
    order
}

/// The complexes of a volume box: base points `origin + spacing * c` for c in
/// `[0, counts)`, x fastest.
#[derive(Clone, Debug)]
pub struct Complexes {
    /// The mesh.
    pub grid: Grid,
    /// Base point of complex (0, 0, 0).
    pub origin: [i64; 3],
    /// Complexes per axis.
    pub counts: [i64; 3],
}

impl Complexes {
    /// Every complex with a tetrahedron whose vertices all lie in `[0, dims - 1]^3`.
    pub fn cover(grid: Grid, dims: [usize; 3]) -> Complexes {
        let s = grid.spacing();
        // A BCC complex reaches one unit below its base point (p - e_b).
        let origin = match grid {
            Grid::Bcc => [-s; 3],
            Grid::Cc => [0; 3],
        };
        let counts = dims.map(|n| ((n as i64 - 1 - origin[0]) / s + 1).max(0));
        Complexes { grid, origin, counts }
    }

    /// Number of complexes.
    pub fn len(&self) -> usize {
        (self.counts[0] * self.counts[1] * self.counts[2]).max(0) as usize
    }

    /// Whether there are none.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Base point of complex `index`.
    pub fn base(&self, index: usize) -> [i64; 3] {
        let i = index as i64;
        let c = [i % self.counts[0], (i / self.counts[0]) % self.counts[1], i / (self.counts[0] * self.counts[1])];
        [0, 1, 2].map(|a| self.origin[a] + self.grid.spacing() * c[a])
    }

    /// The complexes back to front for an orthographic view along `forward`:
    /// each axis walked from its far end (the implicit depth sort of §4.1).
    /// On CC, with the Kuhn types in [`type_order`] inside each cube, this is
    /// a visibility order; on BCC it is not (an octahedron along y of one
    /// complex can lie behind an octahedron along x of a complex drawn
    /// earlier: see the test), so [`Complexes::visible_back_to_front`] sorts
    /// BCC tetrahedra by their circumcentres instead.
    pub fn back_to_front(&self, forward: [f64; 3]) -> Vec<u32> {
        let axis = |a: usize| -> Vec<i64> {
            let n = self.counts[a];
            if forward[a] > 0.0 {
                (0..n).rev().collect()
            } else {
                (0..n).collect()
            }
        };
        let (xs, ys, zs) = (axis(0), axis(1), axis(2));
        let mut out = Vec::with_capacity(self.len());
        for &z in &zs {
            for &y in &ys {
                for &x in &xs {
                    out.push((x + self.counts[0] * (y + self.counts[1] * z)) as u32);
                }
            }
        }
        out
    }

    /// The tetrahedra whose bit is set in `masks` (one mask per complex, bit
    /// t = type t), back to front for an orthographic view along `forward`,
    /// as ids `complex * 16 + type`.
    ///
    /// CC: the traversal of [`Complexes::back_to_front`] with the types in
    /// [`type_order`]. BCC: by decreasing depth of the circumcentre. The
    /// Delaunay tetrahedralisation is acyclic from every viewpoint and the
    /// power distance of the circumspheres from the eye orders it
    /// (Edelsbrunner 1989); with the eye at infinity along -forward that is
    /// the depth of the circumcentre (ties only between cells that do not
    /// overlap on screen). The circumcentre is the base point plus a fixed
    /// offset per type, so the key of a tetrahedron is one dot product.
    pub fn visible_back_to_front(&self, masks: &[u16], forward: [f64; 3]) -> Vec<u32> {
        let types = self.grid.types();
        let walk = self.back_to_front(forward);
        match self.grid {
            Grid::Cc => {
                let order = type_order(&types, forward);
                let mut out = Vec::new();
                for c in walk {
                    let m = masks[c as usize];
                    if m != 0 {
                        out.extend(order.iter().filter(|&&t| m & (1 << t) != 0).map(|&t| c * 16 + t as u32));
                    }
                }
                out
            }
            Grid::Bcc => {
                let dot = |v: [f64; 3]| v[0] * forward[0] + v[1] * forward[1] + v[2] * forward[2];
                let offsets: Vec<f64> = types.iter().map(|t| dot(circumcentre(t))).collect();
                let mut keyed: Vec<(f64, u32)> = Vec::new();
                for c in walk {
                    let m = masks[c as usize];
                    if m == 0 {
                        continue;
                    }
                    let b = self.base(c as usize).map(|x| x as f64);
                    let d = dot(b);
                    for (t, off) in offsets.iter().enumerate() {
                        if m & (1 << t) != 0 {
                            keyed.push((d + off, c * 16 + t as u32));
                        }
                    }
                }
                keyed.sort_by(|a, b| b.0.total_cmp(&a.0));
                keyed.into_iter().map(|(_, id)| id).collect()
            }
        }
    }
}

/// The circumcentre of a tetrahedron type (offsets from its base point).
pub fn circumcentre(t: &[[i64; 3]; 4]) -> [f64; 3] {
    // 2 e_k . (c - v0) = |e_k|^2 for the edges e_k = v_k - v0.
    let inv = inverse_edges(t);
    let h = [1, 2, 3].map(|k| (0..3).map(|i| ((t[k][i] - t[0][i]) as f64).powi(2)).sum::<f64>() / 2.0);
    [0, 1, 2].map(|i| t[0][i] as f64 + (0..3).map(|k| inv[i][k] * h[k]).sum::<f64>())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn barycentric(t: &[[i64; 3]; 4], base: [i64; 3], x: [f64; 3]) -> [f64; 4] {
        let inv = inverse_edges(t);
        let r = [0, 1, 2].map(|i| x[i] - (base[i] + t[0][i]) as f64);
        // Coordinates in the edge basis: x - v0 = sum_k l_k (v_k - v0), l = r E^-1.
        let l = [0, 1, 2].map(|k| (0..3).map(|i| r[i] * inv[i][k]).sum::<f64>());
        [1.0 - l[0] - l[1] - l[2], l[0], l[1], l[2]]
    }

    #[test]
    fn the_tetrahedra_tile_space_once() {
        // Random points of the interior: inside exactly one tetrahedron of
        // the complexes around them (on a face only with probability 0).
        for grid in [Grid::Bcc, Grid::Cc] {
            let types = grid.types();
            let s = grid.spacing();
            let mut seed = 12345u64;
            let mut rnd = || {
                seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
                (seed >> 11) as f64 / (1u64 << 53) as f64
            };
            for _ in 0..300 {
                let x = [4.0 + 4.0 * rnd(), 4.0 + 4.0 * rnd(), 4.0 + 4.0 * rnd()];
                let mut hits = 0;
                let m = 12 / s;
                for bx in 0..m {
                    for by in 0..m {
                        for bz in 0..m {
                            let base = [bx * s, by * s, bz * s];
                            for t in &types {
                                if barycentric(t, base, x).iter().all(|&l| l > 0.0) {
                                    hits += 1;
                                }
                            }
                        }
                    }
                }
                assert_eq!(hits, 1, "{grid:?} at {x:?}");
            }
        }
    }

    #[test]
    fn bcc_types_join_lattice_points_of_both_subgrids() {
        let bcc = Lattice::builtin("bcc").unwrap();
        for t in bcc_types() {
            assert!(t.iter().all(|v| bcc.contains(v)));
            let odd = t.iter().filter(|v| v[0].rem_euclid(2) == 1).count();
            assert_eq!(odd, 2, "two primary, two secondary samples");
        }
    }

    #[test]
    fn inverse_edges_invert() {
        for t in bcc_types().iter().chain(cc_types().iter()) {
            let inv = inverse_edges(t);
            for k in 1..4 {
                for (c, _) in inv.iter().enumerate() {
                    let v: f64 = (0..3).map(|i| (t[k][i] - t[0][i]) as f64 * inv[i][c]).sum();
                    assert!((v - (k - 1 == c) as i32 as f64).abs() < 1e-12);
                }
            }
        }
    }

    #[test]
    fn traversal_walks_each_axis_from_its_far_end() {
        let c = Complexes { grid: Grid::Cc, origin: [0; 3], counts: [3, 2, 2] };
        let o = c.back_to_front([0.5, -0.5, 0.7]);
        assert_eq!(o.len(), 12);
        assert_eq!(c.base(o[0] as usize), [2, 0, 1]);
        assert_eq!(c.base(o[11] as usize), [0, 1, 0]);
    }

    #[test]
    fn the_order_puts_every_tetrahedron_behind_its_face_neighbours_first() {
        // Williams' MPVO condition: for two tetrahedra sharing a face, the one
        // on the far side of the face (along the view) is drawn first.
        use std::collections::HashMap;
        /// Face (sorted vertices) -> (draw position, opposite vertex) of its tetrahedra.
        type Faces = HashMap<[[i64; 3]; 3], Vec<(usize, [i64; 3])>>;
        let views = [[0.3, 0.5, 0.81], [-0.7, 0.2, -0.68], [0.57, -0.57, 0.59], [-0.1, -0.9, 0.42], [0.9, 0.1, -0.1]];
        for grid in [Grid::Bcc, Grid::Cc] {
            let types = grid.types();
            let cx = Complexes::cover(grid, [9, 9, 9]);
            let masks = vec![0xfffu16; cx.len()];
            for fw in views {
                let mut pos: Faces = HashMap::new();
                for (k, id) in cx.visible_back_to_front(&masks, fw).into_iter().enumerate() {
                    let (c, t) = ((id / 16) as usize, (id % 16) as usize);
                    let b = cx.base(c);
                    {
                        let v = types[t].map(|o| [b[0] + o[0], b[1] + o[1], b[2] + o[2]]);
                        for skip in 0..4 {
                            let mut f: Vec<[i64; 3]> = (0..4).filter(|&i| i != skip).map(|i| v[i]).collect();
                            f.sort();
                            pos.entry([f[0], f[1], f[2]]).or_default().push((k, v[skip]));
                        }
                    }
                }
                let mut bad = Vec::new();
                for (f, users) in &pos {
                    if users.len() != 2 || f.iter().flatten().any(|&c| !(0..=8).contains(&c)) {
                        continue;
                    }
                    let d = |a: [i64; 3], b: [i64; 3]| [0, 1, 2].map(|i| (a[i] - b[i]) as f64);
                    let (e1, e2) = (d(f[1], f[0]), d(f[2], f[0]));
                    let n =
                        [e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0]];
                    let side = |p: [i64; 3]| (0..3).map(|i| n[i] * d(p, f[0])[i]).sum::<f64>();
                    let nf: f64 = (0..3).map(|i| n[i] * fw[i]).sum();
                    let ((ka, a), (kb, _)) = (users[0], users[1]);
                    // Orient n from users[0] to users[1]: users[1] is behind when n . fw > 0.
                    let sgn = if side(a) < 0.0 { 1.0 } else { -1.0 };
                    let b_behind = sgn * nf > 0.0;
                    if !(b_behind == (kb < ka) || nf.abs() < 1e-12) {
                        bad.push((*f, users.clone()));
                    }
                }
                bad.sort();
                assert!(
                    bad.is_empty(),
                    "{grid:?} view {fw:?}: {} faces out of order, e.g. {:?}",
                    bad.len(),
                    &bad[..bad.len().min(3)]
                );
            }
        }
    }
}
