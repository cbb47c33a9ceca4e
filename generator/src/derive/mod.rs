//! The whole derivation for one filter: facts, arrangement, symmetry
//! orbits, reference pieces with stencils, polynomials and BB form, and the
//! prefilter. Everything is exact.

pub mod arrangement;
pub mod bb;
pub mod cell_count;
pub mod cone;
pub mod f64_tables;
pub mod factor;
pub mod piece_tables;
pub mod pieces;
pub mod prefilter;
pub mod ridge;
pub mod spline;
pub mod stencil;
pub mod symmetry;

use crate::derive::arrangement::{Arrangement, Frame};
use crate::derive::bb::BbForm;
use crate::derive::pieces::PpForm;
use crate::derive::prefilter::{derive_prefilter, Prefilter};
use crate::derive::ridge::RidgeForm;
use crate::derive::spline::SplineFacts;
use crate::derive::symmetry::{point_group, SignedPerm};
use crate::error::{Error, Result};
use crate::math::exact::Q;
use crate::math::linalg::{mat_vec_i, mat_vec_q, sub_i, sub_q, to_q, IVec, QVec};
use crate::math::poly::Poly;
use crate::spec::lattice::Lattice;
use crate::spec::Filter;
use rayon::prelude::*;
use std::collections::HashMap;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::OnceLock;
pub use stencil::stencil_points;

/// The size of a derivation, known before any polynomial is derived.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
pub struct Estimate {
    /// Evaluation cells per fundamental domain (exact).
    pub cells: usize,
    /// Reference pieces: at least cells / |symmetry group|.
    pub reference_pieces: usize,
    /// Mean stencil size: support volume / det G, rounded up.
    pub stencil: usize,
    /// Polynomials to derive (and emit): reference pieces x stencil.
    pub polynomials: usize,
}

impl Estimate {
    fn new(cells: usize, group: usize, facts: &SplineFacts, lattice: &Lattice) -> Estimate {
        let reference_pieces = cells.div_ceil(group.max(1));
        let stencil = (facts.support_volume as usize).div_ceil(lattice.det().max(1) as usize);
        Estimate { cells, reference_pieces, stencil, polynomials: reference_pieces.saturating_mul(stencil) }
    }
}

/// g(x) = R x + t maps a cell onto its reference cell.
#[derive(Clone, Debug)]
pub struct CellMap {
    /// Index into `Derivation::references`.
    pub reference: usize,
    /// R: a signed permutation from the symmetry group (rows).
    pub rotation: SignedPerm,
    /// t: an integer translation.
    pub translation: IVec,
}

impl CellMap {
    /// g(x) = R x + t.
    pub fn apply(&self, x: &[Q]) -> QVec {
        let r: Vec<QVec> = self.rotation.iter().map(|row| to_q(row)).collect();
        let y = mat_vec_q(&r, x);
        y.iter().zip(&self.translation).map(|(a, b)| a + &Q::int(*b)).collect()
    }

    /// g^-1(k) = R^T (k - t) for integer points.
    pub fn inverse_point(&self, k: &[i64]) -> IVec {
        let rt = crate::derive::symmetry::inverse(&self.rotation);
        mat_vec_i(&rt, &sub_i(k, &self.translation))
    }
}

/// One representative of an orbit of cells.
#[derive(Clone, Debug)]
pub struct ReferencePiece {
    /// Index into `Arrangement::cells`.
    pub cell: usize,
    /// Integer lower corner z of its cube (the cube is o + z + `[0,1]^s`).
    pub corner: IVec,
    /// Vertices in global coordinates.
    pub vertices: Vec<QVec>,
    /// Whether the cell is a simplex (then its BB form exists).
    pub is_simplex: bool,
    /// Lattice points relative to `corner` whose basis function is non-zero here.
    pub stencil: Vec<IVec>,
    /// Polynomial and BB forms, derived on first use: a filter with tens of
    /// thousands of cells can be located and inspected without deriving all.
    forms: OnceLock<Forms>,
    /// The linear-form (ridge) form, derived on first use.
    ridge: OnceLock<RidgeForm>,
}

/// The exact forms of one reference piece.
#[derive(Clone, Debug)]
pub struct Forms {
    /// P_k(u) = phi(o + corner + u - (corner + k)) for each stencil offset k,
    /// in local coordinates u = x - o - corner.
    pub polys: Vec<Poly>,
    /// Bernstein-Bezier form when the cell is a simplex.
    pub bb: Option<BbForm>,
}

/// Everything derived exactly for one filter, from which the evaluators and
/// the emitter work.
#[derive(Clone, Debug)]
pub struct Derivation {
    /// The validated filter this was derived from.
    pub filter: Filter,
    /// Facts of the direction matrix (degree, order, support, normals).
    pub facts: SplineFacts,
    /// The symmetries used (signed permutations that keep L, Xi and the grid).
    pub group: Vec<SignedPerm>,
    /// Knot planes, cube classes and the evaluation cells.
    pub arrangement: Arrangement,
    /// The PP-form of the spline, the source of every piece polynomial.
    pub pp: PpForm,
    /// For every cell, its map onto its reference piece.
    pub maps: Vec<CellMap>,
    /// One reference piece per orbit of cells; `maps` index into it.
    pub references: Vec<ReferencePiece>,
    /// The quasi-interpolation prefilter.
    pub prefilter: Prefilter,
    /// The size estimate the derivation was admitted on.
    pub estimate: Estimate,
    pub(crate) f64_cache: std::sync::OnceLock<f64_tables::F64Tables>,
}

impl Derivation {
    /// Derives everything for a validated filter, refusing early (before the
    /// costly work) when it would exceed the filter's caps.
    ///
    /// # Errors
    ///
    /// [`Error::StencilCap`], [`Error::CellCap`] and [`Error::PolynomialCap`] when a
    /// cap is exceeded, and [`Error::Prefilter`] from [`derive_prefilter`].
    pub fn new(filter: &Filter) -> Result<Derivation> {
        let facts = SplineFacts::new(filter);
        let lattice = &filter.lattice;
        // Cheap early refusal: the stencil is about support volume / det G.
        let estimate = (facts.support_volume / lattice.det()) as usize;
        if estimate > filter.caps.max_stencil {
            return Err(Error::StencilCap { size: estimate, cap: filter.caps.max_stencil });
        }
        // Know the size of the answer before paying for it: the cells are
        // counted exactly without cutting, the reference pieces are at least
        // cells / |group|, and a stencil holds about support volume / det G
        // samples (the exact mean over all positions).
        let frame = Frame::new(&facts, lattice);
        let o = frame.grid_offset.clone();
        let group: Vec<SignedPerm> = point_group(filter)
            .into_iter()
            .filter(|r| {
                let rq: Vec<QVec> = r.iter().map(|row| to_q(row)).collect();
                sub_q(&mat_vec_q(&rq, &o), &o).iter().all(|x| x.is_integer())
            })
            .collect();
        let cells = frame
            .count_cells_within(filter.caps.max_cells)
            .map_err(|lower| Error::CellCap { cells: lower, cap: filter.caps.max_cells })?;
        let estimate = Estimate::new(cells, group.len(), &facts, lattice);
        if estimate.polynomials > filter.caps.max_polynomials {
            return Err(Error::PolynomialCap {
                polynomials: estimate.polynomials,
                pieces: estimate.reference_pieces,
                stencil: estimate.stencil,
                exact: false,
                cap: filter.caps.max_polynomials,
            });
        }
        let arrangement = Arrangement::from_frame(frame, lattice);
        debug_assert_eq!(arrangement.cells.len(), cells, "counted cells = cut cells");
        let pp = PpForm::new(&facts, lattice.det());
        let maps = cell_maps(&arrangement, lattice, &group);
        let reference_cells: Vec<usize> =
            maps.iter().enumerate().filter(|(i, m)| m.reference == *i).map(|(i, _)| i).collect();
        let ref_of_cell: HashMap<usize, usize> = reference_cells.iter().enumerate().map(|(r, &c)| (c, r)).collect();
        let references: Vec<ReferencePiece> =
            reference_cells.par_iter().map(|&i| reference_piece(&arrangement, &facts, lattice, i)).collect();
        // Every cell of an orbit has its reference's stencil size.
        let max_stencil = references.iter().map(|r| r.stencil.len()).max().unwrap_or(0);
        if max_stencil > filter.caps.max_stencil {
            return Err(Error::StencilCap { size: max_stencil, cap: filter.caps.max_stencil });
        }
        let polynomials: usize = references.iter().map(|r| r.stencil.len()).sum();
        if polynomials > filter.caps.max_polynomials {
            return Err(Error::PolynomialCap {
                polynomials,
                pieces: references.len(),
                stencil: max_stencil,
                exact: true,
                cap: filter.caps.max_polynomials,
            });
        }
        let maps = maps.into_iter().map(|m| CellMap { reference: ref_of_cell[&m.reference], ..m }).collect();
        let prefilter = derive_prefilter(filter, &group, facts.approximation_order)?;
        Ok(Derivation {
            filter: filter.clone(),
            facts,
            group,
            arrangement,
            pp,
            maps,
            references,
            prefilter,
            estimate,
            f64_cache: Default::default(),
        })
    }

    /// Polynomials to derive and emit: the stencil sizes of all reference pieces.
    pub fn polynomials(&self) -> usize {
        self.references.iter().map(|r| r.stencil.len()).sum()
    }

    /// Derives the forms of every reference piece now, in parallel on the
    /// machine's cores (they are otherwise derived lazily on first use),
    /// calling `progress(done, total)` as pieces finish.
    pub fn derive_all_forms(&self, progress: &(dyn Fn(usize, usize) + Sync)) {
        let done = AtomicUsize::new(0);
        let total = self.references.len();
        (0..total).into_par_iter().for_each(|ri| {
            self.forms(ri);
            progress(done.fetch_add(1, Ordering::Relaxed) + 1, total);
        });
    }

    /// The polynomial (and BB) forms of reference piece `ri`, derived once.
    pub fn forms(&self, ri: usize) -> &Forms {
        let r = &self.references[ri];
        r.forms.get_or_init(|| {
            let c = &self.arrangement.cells[r.cell];
            let origin = self.cube_origin(&r.corner);
            let polys: Vec<Poly> = r
                .stencil
                .iter()
                .map(|k| self.pp.local_piece(&origin, &c.interior, &crate::math::linalg::add_i(&r.corner, k)))
                .collect();
            let bb = r.is_simplex.then(|| {
                let local: Vec<QVec> = r.vertices.iter().map(|v| sub_q(v, &origin)).collect();
                BbForm::new(&local, &polys, self.facts.degree)
            });
            Forms { polys, bb }
        })
    }

    /// The linear-form (ridge) form of reference piece `ri`, derived once:
    /// the same polynomials as [`Derivation::forms`], kept as sums of
    /// products of powers of knot-plane linear forms.
    pub fn ridge(&self, ri: usize) -> &RidgeForm {
        let r = &self.references[ri];
        r.ridge.get_or_init(|| {
            let c = &self.arrangement.cells[r.cell];
            let origin = self.cube_origin(&r.corner);
            let stencil: Vec<IVec> = r.stencil.iter().map(|k| crate::math::linalg::add_i(&r.corner, k)).collect();
            RidgeForm::new(&self.pp, &origin, &c.interior, &stencil)
        })
    }

    /// o + z: the lower corner of the grid cube with integer corner z.
    pub fn cube_origin(&self, z: &[i64]) -> QVec {
        (0..z.len()).map(|i| &self.arrangement.grid_offset[i] + &Q::int(z[i])).collect()
    }

    /// The largest stencil of any reference piece (0 without pieces).
    pub fn max_stencil(&self) -> usize {
        self.references.iter().map(|r| r.stencil.len()).max().unwrap_or(0)
    }

    /// The polynomials of any cell, obtained directly from the PP-form (not
    /// through symmetry): (stencil offsets relative to the cell's corner, polys).
    pub fn cell_polys_direct(&self, cell: usize) -> (Vec<IVec>, Vec<Poly>) {
        let c = &self.arrangement.cells[cell];
        let z = self.arrangement.corner(cell);
        let origin = self.cube_origin(z);
        let pts = stencil_points(&self.facts, &self.filter.lattice, &c.interior);
        let polys = pts.iter().map(|j| self.pp.local_piece(&origin, &c.interior, j)).collect();
        (pts.iter().map(|j| sub_i(j, z)).collect(), polys)
    }
}

fn reference_piece(arr: &Arrangement, facts: &SplineFacts, lattice: &Lattice, cell: usize) -> ReferencePiece {
    let c = &arr.cells[cell];
    let z = arr.corner(cell).clone();
    let pts = stencil_points(facts, lattice, &c.interior);
    ReferencePiece {
        cell,
        stencil: pts.iter().map(|j| sub_i(j, &z)).collect(),
        corner: z,
        vertices: c.polytope.vertices.clone(),
        is_simplex: c.polytope.is_simplex(),
        forms: OnceLock::new(),
        ridge: OnceLock::new(),
    }
}

/// For each cell, the first (in group order) map onto the least cell of its
/// orbit. `reference` holds a cell index here; the caller renumbers.
fn cell_maps(arr: &Arrangement, lattice: &Lattice, group: &[SignedPerm]) -> Vec<CellMap> {
    let s = arr.grid_offset.len();
    // A cell is found by its class and its vertex centroid (an interior
    // point, kept by the affine map g): one matrix-vector product per
    // symmetry instead of one per vertex and a sort.
    let centroid = |vs: &[QVec]| -> QVec {
        let n = Q::int(vs.len() as i64);
        (0..s).map(|i| vs.iter().map(|v| v[i].clone()).sum::<Q>() / n.clone()).collect()
    };
    let index: HashMap<(usize, QVec), usize> =
        arr.cells.iter().enumerate().map(|(i, c)| ((c.class, centroid(&c.polytope.vertices)), i)).collect();
    let o = &arr.grid_offset;
    let rqs: Vec<Vec<QVec>> = group.iter().map(|r| r.iter().map(|row| to_q(row)).collect()).collect();
    arr.cells
        .par_iter()
        .map(|c| {
            let z = &arr.classes[c.class];
            let mid = centroid(&c.polytope.vertices);
            let mut best: Option<CellMap> = None;
            let mut best_cell = usize::MAX;
            for (r, rq) in group.iter().zip(&rqs) {
                // Image cube lower corner: componentwise min of R(o+z) and R(o+z+1).
                let lo: QVec = (0..s).map(|k| &o[k] + &Q::int(z[k])).collect();
                let hi: QVec = lo.iter().map(|x| x + &Q::one()).collect();
                let (a, b) = (mat_vec_q(rq, &lo), mat_vec_q(rq, &hi));
                let img_lo: QVec = a.iter().zip(&b).map(|(x, y)| x.clone().min(y.clone())).collect();
                let zq = sub_q(&img_lo, o);
                // The group keeps the grid (R o - o is integral, see Derivation::new).
                let zi: IVec =
                    zq.iter().map(|x| x.to_i64().expect("a grid-keeping R maps corners to integers")).collect();
                let (ci, l) = arr.locate_cube(lattice, &zi);
                let t: IVec = l.iter().map(|x| -x).collect();
                let image = crate::math::linalg::add_q(&mat_vec_q(rq, &mid), &to_q(&t));
                let j = *index.get(&(ci, image)).expect("symmetries map cells onto cells");
                if j < best_cell {
                    best_cell = j;
                    best = Some(CellMap { reference: j, rotation: r.clone(), translation: t });
                }
            }
            best.expect("identity is in the group")
        })
        .collect()
}
