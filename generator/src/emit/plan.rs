//! The evaluation plan: how a shader finds, from a point x, the reference
//! piece, the map g and the fetch positions, with arithmetic and `select`
//! only (docs/BOX_SPLINES.md §3.8, §3.10). Plain data that `emit` turns into WGSL
//! and that [`Plan::eval_f64`] mirrors on the CPU, so the plan is tested
//! against the exact evaluator before any GPU runs it.
//!
//! Every path ends in a *frame*: an integer base b and a signed permutation M
//! with x = b + M w. Candidates are cells in w-space, each with its map
//! y = R w + t onto a reference piece; the fetch for stencil point K of the
//! reference is at b + M R^T (K - t).

use crate::derive::symmetry::{inverse, SignedPerm};
use crate::derive::Derivation;
use crate::math::exact::Q;
use crate::math::linalg::{mat_vec_i, sub_i, to_q, IVec, QVec};
use crate::math::polytope::{HalfSpace, Polytope};

/// How the frame is found.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Locate {
    /// Fold every coordinate about the nearest point of 2Z^s (u = |x - c|),
    /// then, if `sort`, sort u descending (a sorting network).
    Fold {
        /// Whether u is then sorted descending (possible when the group holds
        /// every axis permutation and the grid offset is equal on all axes).
        sort: bool,
    },
    /// Select over all cube classes and cells (any lattice, any filter).
    Generic,
}

/// One cell that the point may fall in after locating, in w-space.
#[derive(Clone, Debug)]
pub struct Candidate {
    /// Index into `Derivation::references`.
    pub reference: usize,
    /// R of y = R w + t (rows).
    pub rotation: SignedPerm,
    /// t of y = R w + t.
    pub translation: IVec,
    /// Inside test: n . w <= b for all.
    pub tests: Vec<HalfSpace>,
    /// Generic path: the cube class this candidate lives in.
    pub class: usize,
    /// Fetch offsets q = R^T (K - t) per fetch slot (in fetch order).
    pub offsets: Vec<IVec>,
}

/// How the fast shader locates a point: the frame, the candidate cells and
/// the fetch slots of every reference.
#[derive(Clone, Debug)]
pub struct Plan {
    /// Dimension s.
    pub dim: usize,
    /// How the frame is found.
    pub locate: Locate,
    /// The grid offset o of the arrangement.
    pub grid_offset: QVec,
    /// The cells the located point may fall in; the last satisfied one wins.
    pub candidates: Vec<Candidate>,
    /// Per reference: stencil index fetched in each slot (None: slot unused).
    pub slots: Vec<Vec<Option<usize>>>,
    /// Generic path: class representatives (nice), their canonical reductions
    /// and the lower-triangular Hermite basis of L (columns).
    pub classes: Vec<IVec>,
    /// Generic path: the canonical reduction of each class representative.
    pub class_keys: Vec<IVec>,
    /// Generic path: the lower-triangular Hermite basis of L (columns).
    pub hermite: Vec<IVec>,
    /// Vector adds to walk the fetch positions (axis-aligned order), and the
    /// adds a plain matrix-vector product per fetch would cost.
    pub vector_adds: usize,
    /// Adds a plain matrix-vector product per fetch would cost.
    pub matvec_adds: usize,
}

/// Where a point falls (see [`Plan::locate_f64`]): x = base + M w.
#[derive(Clone, Debug)]
pub struct Located {
    /// Index of the chosen candidate.
    pub candidate: usize,
    /// Integer base b of the frame.
    pub base: IVec,
    /// Signed permutation M of the frame (rows).
    pub m: Vec<IVec>,
    /// Local coordinates in the chosen candidate's reference piece.
    pub u: Vec<f64>,
}

impl Located {
    /// base + M q for the candidate's offset in `slot`.
    fn slot_position(&self, c: &Candidate, slot: usize) -> IVec {
        let q = &c.offsets[slot];
        let s = q.len();
        (0..s).map(|i| self.base[i] + (0..s).map(|j| self.m[i][j] * q[j]).sum::<i64>()).collect()
    }
}

fn signed_identity(s: usize) -> SignedPerm {
    (0..s).map(|i| (0..s).map(|j| (i == j) as i64).collect()).collect()
}

impl Plan {
    /// The plan the fast shaders use (folding with the sorting network where it applies).
    pub fn new(d: &Derivation) -> Plan {
        Plan::build(d, true)
    }

    /// Folding without the sorting network: candidates cover the whole folded
    /// cube `[0,1]^s` (used for per-cube bounds).
    pub fn without_sort(d: &Derivation) -> Plan {
        Plan::build(d, false)
    }

    fn build(d: &Derivation, allow_sort: bool) -> Plan {
        let s = d.facts.dim;
        let o = &d.arrangement.grid_offset;
        let lattice = &d.filter.lattice;
        let has = |m: &SignedPerm| d.group.contains(m);
        let half = Q::frac(1, 2);
        let can_fold = (0..s).all(|i| {
            let mut r = signed_identity(s);
            r[i][i] = -1;
            let mut e = vec![0; s];
            e[i] = 2;
            has(&r) && lattice.contains(&e) && (o[i].is_zero() || o[i] == half)
        });
        let can_sort = can_fold
            && allow_sort
            && o.iter().all(|x| *x == o[0])
            && crate::derive::symmetry::signed_permutations(s)
                .into_iter()
                .filter(|m| m.iter().all(|row| row.iter().all(|&x| x >= 0)))
                .all(|m| has(&m));
        let locate = if can_fold { Locate::Fold { sort: can_sort } } else { Locate::Generic };
        let mut candidates = match locate {
            Locate::Fold { sort } => fold_candidates(d, sort),
            Locate::Generic => generic_candidates(d),
        };
        // Slots: each reference's stencil in axis-aligned order of its first candidate.
        let nrefs = d.references.len();
        let mut slots: Vec<Vec<Option<usize>>> = vec![vec![]; nrefs];
        let nslots = candidates.iter().map(|c| d.references[c.reference].stencil.len()).max().unwrap_or(0);
        for r in 0..nrefs {
            let Some(first) = candidates.iter().find(|c| c.reference == r) else { continue };
            let stencil = &d.references[r].stencil;
            let qs: Vec<IVec> = stencil.iter().map(|k| fetch_offset(d, first, r, k)).collect();
            let order = crate::emit::fetch_order::axis_aligned_order(&qs);
            slots[r] = (0..nslots).map(|i| order.get(i).copied()).collect();
        }
        for c in candidates.iter_mut() {
            let r = c.reference;
            let stencil = &d.references[r].stencil;
            c.offsets = slots[r]
                .iter()
                .map(|k| match k {
                    Some(k) => fetch_offset(d, c, r, &stencil[*k]),
                    None => vec![0; s],
                })
                .collect();
        }
        let single = candidates.len() == 1;
        let vector_adds = if single { crate::emit::fetch_order::walk_adds(&candidates[0].offsets) } else { nslots * s };
        let matvec_adds = nslots * s;
        let classes = d.arrangement.classes.clone();
        let class_keys = classes.iter().map(|c| lattice.reduce(c)).collect();
        Plan {
            dim: s,
            locate,
            grid_offset: o.clone(),
            candidates,
            slots,
            classes,
            class_keys,
            hermite: lattice.hermite_basis().to_vec(),
            vector_adds,
            matvec_adds,
        }
    }

    /// Samples fetched per evaluation: the most slots any reference uses.
    pub fn fetches(&self) -> usize {
        self.slots.iter().map(|s| s.len()).max().unwrap_or(0)
    }

    /// References some candidate uses.
    pub fn used_references(&self) -> Vec<usize> {
        let mut r: Vec<usize> = self.candidates.iter().map(|c| c.reference).collect();
        r.sort();
        r.dedup();
        r
    }

    /// Where x falls: the chosen candidate, its frame and the local
    /// coordinates of its reference piece (the emitted code's steps in f64).
    pub fn locate_f64(&self, d: &Derivation, x: &[f64]) -> Located {
        let s = self.dim;
        let (base, m, w, class) = self.frame_f64(x);
        // Last satisfied candidate wins (a select chain).
        let mut chosen = 0;
        for (i, c) in self.candidates.iter().enumerate() {
            let inside = c.tests.iter().all(|h| {
                h.normal.iter().zip(&w).map(|(n, wi)| n.to_f64() * wi).sum::<f64>() <= h.bound.to_f64() + 1e-12
            });
            let class_ok = class.is_none_or(|k| k == c.class);
            if inside && class_ok {
                chosen = i;
            }
        }
        let c = &self.candidates[chosen];
        let r = &d.references[c.reference];
        // y = R w + t; local u = y - o - corner.
        let y: Vec<f64> = (0..s)
            .map(|i| c.rotation[i].iter().zip(&w).map(|(a, b)| *a as f64 * b).sum::<f64>() + c.translation[i] as f64)
            .collect();
        let u: Vec<f64> = (0..s).map(|i| y[i] - self.grid_offset[i].to_f64() - r.corner[i] as f64).collect();
        Located { candidate: chosen, base, m, u }
    }

    /// CPU mirror of the emitted code: (value, gradient) at x.
    pub fn eval_f64(&self, d: &Derivation, x: &[f64], data: &dyn Fn(&[i64]) -> f64) -> (f64, Vec<f64>) {
        let s = self.dim;
        let at = self.locate_f64(d, x);
        let c = &self.candidates[at.candidate];
        let tab = d.f64_reference(c.reference);
        let mut value = 0.0;
        let mut grad_u = vec![0.0; s];
        for (slot, k) in self.slots[c.reference].iter().enumerate() {
            let Some(k) = k else { continue };
            let v = data(&at.slot_position(c, slot));
            let (pv, pg) = crate::math::poly::eval_poly_f64(&tab.exps, &tab.coeffs[*k], &at.u);
            value += v * pv;
            for i in 0..s {
                grad_u[i] += v * pg[i];
            }
        }
        // grad_x = M R^T grad_y
        let rt = inverse(&c.rotation);
        let gw: Vec<f64> = (0..s).map(|i| (0..s).map(|j| rt[i][j] as f64 * grad_u[j]).sum()).collect();
        let gx: Vec<f64> = (0..s).map(|i| (0..s).map(|j| at.m[i][j] as f64 * gw[j]).sum()).collect();
        (value, gx)
    }

    /// Lattice position of stencil index `k` of the located candidate's reference.
    pub fn stencil_position(&self, at: &Located, k: usize) -> IVec {
        let c = &self.candidates[at.candidate];
        let slot = self.slots[c.reference]
            .iter()
            .position(|x| *x == Some(k))
            .expect("every stencil index of a reference has a slot");
        at.slot_position(c, slot)
    }

    /// (base b, M, w, class) with x = b + M w.
    fn frame_f64(&self, x: &[f64]) -> (IVec, Vec<IVec>, Vec<f64>, Option<usize>) {
        let s = self.dim;
        match self.locate {
            Locate::Fold { sort } => {
                let c: IVec = x.iter().map(|v| 2 * (v / 2.0).round() as i64).collect();
                let d: Vec<f64> = (0..s).map(|i| x[i] - c[i] as f64).collect();
                let sign: Vec<i64> = d.iter().map(|v| if *v >= 0.0 { 1 } else { -1 }).collect();
                let u: Vec<f64> = d.iter().map(|v| v.abs()).collect();
                // perm[i] = which axis of u lands in slot i (descending).
                let mut perm: Vec<usize> = (0..s).collect();
                if sort {
                    perm.sort_by(|a, b| u[*b].total_cmp(&u[*a]).then(a.cmp(b)));
                }
                let w: Vec<f64> = perm.iter().map(|&a| u[a]).collect();
                // x = c + S Pi^T w: column i of M is sign[perm[i]] e_{perm[i]}.
                let mut m = vec![vec![0i64; s]; s];
                for (i, &a) in perm.iter().enumerate() {
                    m[a][i] = sign[a];
                }
                (c, m, w, None)
            }
            Locate::Generic => {
                let z: IVec = (0..s).map(|i| (x[i] - self.grid_offset[i].to_f64()).floor() as i64).collect();
                let key = reduce_with(&self.hermite, &z);
                let class = self
                    .class_keys
                    .iter()
                    .position(|k| *k == key)
                    .expect("class_keys holds the reduced key of every class of Z^s / L");
                let l = sub_i(&z, &self.classes[class]);
                let w: Vec<f64> = (0..s).map(|i| x[i] - l[i] as f64).collect();
                (l, signed_identity(s), w, Some(class))
            }
        }
    }
}

/// Canonical class representative via a lower-triangular Hermite basis.
pub fn reduce_with(hermite: &[IVec], v: &[i64]) -> IVec {
    let mut x = v.to_vec();
    for i in 0..x.len() {
        let h = hermite[i][i];
        let q = x[i].div_euclid(h);
        for (r, xr) in x.iter_mut().enumerate().skip(i) {
            *xr -= q * hermite[i][r];
        }
    }
    x
}

/// q = R^T (K - t) for stencil offset k of reference r (K = corner + k).
fn fetch_offset(d: &Derivation, c: &Candidate, r: usize, k: &[i64]) -> IVec {
    let corner = &d.references[r].corner;
    let kk: IVec = corner.iter().zip(k).map(|(a, b)| a + b).collect();
    mat_vec_i(&inverse(&c.rotation), &sub_i(&kk, &c.translation))
}

/// The fold chamber F: `[0,1]^s`, and u_1 >= ... >= u_s when sorting.
fn chamber(s: usize, sort: bool) -> Vec<HalfSpace> {
    let mut hs = Vec::new();
    for i in 0..s {
        let mut e = vec![Q::zero(); s];
        e[i] = Q::one();
        hs.push(HalfSpace { normal: e.clone(), bound: Q::one() });
        hs.push(HalfSpace { normal: e.iter().map(|x| -x).collect(), bound: Q::zero() });
    }
    if sort {
        for i in 0..s - 1 {
            let mut n = vec![Q::zero(); s];
            n[i + 1] = Q::one();
            n[i] = -Q::one();
            hs.push(HalfSpace { normal: n, bound: Q::zero() });
        }
    }
    hs
}

/// p intersected with the half-spaces; None unless full-dimensional.
fn clip(p: &Polytope, hs: &[HalfSpace]) -> Option<Polytope> {
    let mut cur = p.clone();
    for h in hs {
        if let Some((lo, _)) = cur.split(&h.normal, &h.bound) {
            cur = lo;
        } else if cur.vertices.iter().any(|v| h.slack(v).is_negative()) {
            return None; // entirely on the outer side
        }
    }
    Some(cur)
}

fn fold_candidates(d: &Derivation, sort: bool) -> Vec<Candidate> {
    let s = d.facts.dim;
    let arr = &d.arrangement;
    let lattice = &d.filter.lattice;
    let f = chamber(s, sort);
    // Cubes o + z + `[0,1]^s` meeting `[0,1]^s`: z_i = 0 when o_i = 0, z_i in {-1, 0} when o_i = 1/2.
    let mut zs: Vec<IVec> = vec![vec![]];
    for i in 0..s {
        let opts: Vec<i64> = if arr.grid_offset[i].is_zero() { vec![0] } else { vec![-1, 0] };
        zs = zs
            .into_iter()
            .flat_map(|p| {
                opts.iter().map(move |&k| {
                    let mut q = p.clone();
                    q.push(k);
                    q
                })
            })
            .collect();
    }
    let mut out = Vec::new();
    for z in zs {
        let (ci, l) = arr.locate_cube(lattice, &z);
        let lq = to_q(&l);
        for (cell_index, cell) in arr.cells.iter().enumerate() {
            if cell.class != ci {
                continue;
            }
            let moved: Vec<HalfSpace> = cell
                .polytope
                .facets
                .iter()
                .map(|h| HalfSpace {
                    normal: h.normal.clone(),
                    bound: &h.bound + &crate::math::linalg::dot_q(&h.normal, &lq),
                })
                .collect();
            let Some(p) = Polytope::from_halfspaces(moved.clone()) else { continue };
            let Some(clipped) = clip(&p, &f) else { continue };
            // Tests: facets of the clipped piece that are not chamber facets.
            let tests: Vec<HalfSpace> =
                clipped.facets.iter().filter(|h| !f.iter().any(|g| same_plane(g, h))).cloned().collect();
            let map = &d.maps[cell_index];
            // y = R (w - l) + t
            let t = sub_i(&map.translation, &mat_vec_i(&map.rotation, &l));
            out.push(Candidate {
                reference: map.reference,
                rotation: map.rotation.clone(),
                translation: t,
                tests,
                class: 0,
                offsets: vec![],
            });
        }
    }
    out
}

fn same_plane(a: &HalfSpace, b: &HalfSpace) -> bool {
    a.normal == b.normal && a.bound == b.bound
}

fn generic_candidates(d: &Derivation) -> Vec<Candidate> {
    d.arrangement
        .cells
        .iter()
        .zip(&d.maps)
        .map(|(cell, map)| Candidate {
            reference: map.reference,
            rotation: map.rotation.clone(),
            translation: map.translation.clone(),
            tests: cell.polytope.facets.clone(),
            class: cell.class,
            offsets: vec![],
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::spec::catalog;

    /// The plan (fold/sort or generic, candidates, fetch offsets) reproduces the
    /// exact evaluator at random points, value and gradient.
    #[test]
    fn plan_matches_evaluator_for_the_catalog() {
        for name in catalog::names() {
            let d = Derivation::new(&catalog::get(name).unwrap()).unwrap();
            let plan = Plan::new(&d);
            let mut seed = 12345u64;
            let mut rnd = || {
                seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
                ((seed >> 33) as f64 / (1u64 << 31) as f64) * 12.0 - 6.0
            };
            let data = |j: &[i64]| (j.iter().fold(17i64, |h, &x| h.wrapping_mul(31).wrapping_add(x)) % 23) as f64;
            for _ in 0..300 {
                let x: Vec<f64> = (0..d.facts.dim).map(|_| rnd()).collect();
                let (v, g) = plan.eval_f64(&d, &x, &data);
                let (ve, ge) = d.eval_f64(&x, &data);
                assert!((v - ve).abs() < 1e-9 * (1.0 + ve.abs()), "{name} at {x:?}: {v} vs {ve} ({:?})", plan.locate);
                for (a, b) in g.iter().zip(&ge) {
                    assert!((a - b).abs() < 1e-7 * (1.0 + b.abs()), "{name} grad at {x:?}: {g:?} vs {ge:?}");
                }
            }
        }
    }

    #[test]
    fn folding_applies_where_the_symmetries_allow() {
        let p = |n: &str| Plan::new(&Derivation::new(&catalog::get(n).unwrap()).unwrap());
        assert_eq!(p("bcc7").locate, Locate::Fold { sort: true });
        assert_eq!(p("bcc7").candidates.len(), 1);
        assert_eq!(p("bcc7").fetches(), 30);
        assert_eq!(p("fcc6").fetches(), 16);
        assert_eq!(p("zp").locate, Locate::Fold { sort: true });
        // Courant has no single-axis reflections: generic select fallback.
        assert_eq!(p("courant").locate, Locate::Generic);
    }
}
