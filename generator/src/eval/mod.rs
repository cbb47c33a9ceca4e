//! Evaluation of a spline with data on the lattice, through the reference
//! pieces and the maps g: the path the shaders take (locate the cube and
//! cell, map to the reference piece, fetch at g^-1(k), evaluate the
//! reference polynomials). Exact (rationals) and f64.

pub mod oracle;

use crate::derive::Derivation;
use crate::math::exact::Q;
use crate::math::linalg::{add_i, sub_q, to_q, IVec, QVec};
use crate::math::poly::{eval_poly_f64, eval_poly_f64_hessian};

/// Value, gradient and Hessian (row-major s x s) at a point.
pub type SecondOrder = (f64, Vec<f64>, Vec<f64>);

/// Where a point falls: its cell (in the representative cube) and the
/// lattice vector l that moves the representative cube onto the point's cube.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Location {
    /// Index into `Arrangement::cells` (a cell of the representative cube).
    pub cell: usize,
    /// Lattice vector l from the representative cube to the point's cube.
    pub lattice_shift: IVec,
}

impl Derivation {
    /// Finds the cell containing x (any containing cell on boundaries).
    ///
    /// # Panics
    ///
    /// If a coordinate of `x` is beyond the i64 range.
    pub fn locate(&self, x: &[Q]) -> Location {
        let arr = &self.arrangement;
        let z: IVec = x
            .iter()
            .zip(&arr.grid_offset)
            .map(|(a, o)| (a - o).floor_i64().expect("x is within the i64 range (the precondition of locate)"))
            .collect();
        let (ci, l) = arr.locate_cube(&self.filter.lattice, &z);
        let xr = sub_q(x, &to_q(&l));
        let cell = arr
            .cells
            .iter()
            .enumerate()
            .find(|(_, c)| c.class == ci && c.polytope.contains(&xr))
            .map(|(i, _)| i)
            .expect("the cells of a class cover its closed cube, which holds xr");
        Location { cell, lattice_shift: l }
    }

    /// For a location: (reference index, local coordinates u in the reference
    /// cube, the data positions of the reference stencil).
    fn reference_frame(&self, x: &[Q], loc: &Location) -> (usize, QVec, Vec<IVec>) {
        let map = &self.maps[loc.cell];
        let r = &self.references[map.reference];
        let xr = sub_q(x, &to_q(&loc.lattice_shift));
        let y = map.apply(&xr);
        let origin: QVec = (0..y.len()).map(|i| &self.arrangement.grid_offset[i] + &Q::int(r.corner[i])).collect();
        let u = sub_q(&y, &origin);
        let fetch =
            r.stencil.iter().map(|k| add_i(&loc.lattice_shift, &map.inverse_point(&add_i(&r.corner, k)))).collect();
        (map.reference, u, fetch)
    }

    /// The spline sum_j data(j) phi(x - j), exactly.
    ///
    /// # Panics
    ///
    /// As [`Derivation::locate`].
    pub fn eval_exact(&self, x: &[Q], data: &dyn Fn(&[i64]) -> Q) -> Q {
        let loc = self.locate(x);
        let (ri, u, fetch) = self.reference_frame(x, &loc);
        self.forms(ri).polys.iter().zip(&fetch).map(|(p, j)| data(j) * p.eval(&u)).sum()
    }

    /// The same value through the BB form (de Casteljau-free direct sum) when
    /// the reference piece is a simplex; None otherwise.
    pub fn eval_exact_bb(&self, x: &[Q], data: &dyn Fn(&[i64]) -> Q) -> Option<Q> {
        let loc = self.locate(x);
        let (ri, u, fetch) = self.reference_frame(x, &loc);
        let bb = self.forms(ri).bb.as_ref()?;
        let c: QVec = fetch.iter().map(|j| data(j)).collect();
        Some(bb.eval(&bb.coefficients(&c), &bb.barycentric(&u)))
    }

    /// f64 evaluation: value and gradient (∂/∂x), through the same maps.
    pub fn eval_f64(&self, x: &[f64], data: &dyn Fn(&[i64]) -> f64) -> (f64, Vec<f64>) {
        let (v, g, _) = self.eval_f64_order(x, data, 1);
        (v, g)
    }

    /// f64 evaluation: value, gradient and Hessian (∂²/∂x_i∂x_j, row-major),
    /// through the same maps.
    pub fn eval_f64_hessian(&self, x: &[f64], data: &dyn Fn(&[i64]) -> f64) -> SecondOrder {
        self.eval_f64_order(x, data, 2)
    }

    /// Value, gradient and (order 2) Hessian; the Hessian is empty below order 2.
    fn eval_f64_order(&self, x: &[f64], data: &dyn Fn(&[i64]) -> f64, order: usize) -> SecondOrder {
        let t = self.f64_tables();
        let s = x.len();
        let arr = &self.arrangement;
        let z: IVec = (0..s).map(|i| (x[i] - t.offset[i]).floor() as i64).collect();
        let (ci, l) = arr.locate_cube(&self.filter.lattice, &z);
        let xr: Vec<f64> = (0..s).map(|i| x[i] - l[i] as f64).collect();
        // Most-inside cell of the class: robust on boundaries.
        let cell = t
            .cells
            .iter()
            .enumerate()
            .filter(|(i, _)| arr.cells[*i].class == ci)
            .map(|(i, hs)| {
                let slack = hs
                    .iter()
                    .map(|(n, b)| b - n.iter().zip(&xr).map(|(a, c)| a * c).sum::<f64>())
                    .fold(f64::INFINITY, f64::min);
                (i, slack)
            })
            .max_by(|a, b| a.1.total_cmp(&b.1))
            .expect("every cube class has at least one cell")
            .0;
        self.eval_f64_in_cell(cell, &l, &xr, data, order)
    }
}

impl Derivation {
    /// f64 value and gradient (∂/∂x) of every polynomial piece whose closed
    /// cell lies within `tol` (max norm, in x units) of x, each piece's
    /// polynomial evaluated at x itself: the one-sided limits of the spline
    /// at a point on (or within `tol` of) knot planes. Cells of neighbouring
    /// cubes count when x is within `tol` of a grid plane. A point inside a
    /// cell, farther than `tol` from its facets, gets one entry, equal to
    /// [`Derivation::eval_f64`]; the list is never empty.
    pub fn eval_f64_pieces_near(&self, x: &[f64], data: &dyn Fn(&[i64]) -> f64, tol: f64) -> Vec<(f64, Vec<f64>)> {
        self.pieces_near(x, data, tol, 1).into_iter().map(|(v, g, _)| (v, g)).collect()
    }

    /// [`Derivation::eval_f64_pieces_near`] with each piece's Hessian.
    pub fn eval_f64_pieces_near_hessian(&self, x: &[f64], data: &dyn Fn(&[i64]) -> f64, tol: f64) -> Vec<SecondOrder> {
        self.pieces_near(x, data, tol, 2)
    }

    fn pieces_near(&self, x: &[f64], data: &dyn Fn(&[i64]) -> f64, tol: f64, order: usize) -> Vec<SecondOrder> {
        let t = self.f64_tables();
        let s = x.len();
        let arr = &self.arrangement;
        let ranges: Vec<(i64, i64)> = (0..s)
            .map(|i| ((x[i] - t.offset[i] - tol).floor() as i64, (x[i] - t.offset[i] + tol).floor() as i64))
            .collect();
        let mut out = Vec::new();
        let mut z: IVec = ranges.iter().map(|r| r.0).collect();
        loop {
            let (ci, l) = arr.locate_cube(&self.filter.lattice, &z);
            let xr: Vec<f64> = (0..s).map(|i| x[i] - l[i] as f64).collect();
            for (cell, hs) in t.cells.iter().enumerate() {
                if arr.cells[cell].class != ci {
                    continue;
                }
                let slack = hs
                    .iter()
                    .map(|(n, b)| {
                        let norm: f64 = n.iter().map(|a| a.abs()).sum();
                        (b - n.iter().zip(&xr).map(|(a, c)| a * c).sum::<f64>()) / norm
                    })
                    .fold(f64::INFINITY, f64::min);
                if slack >= -tol {
                    out.push(self.eval_f64_in_cell(cell, &l, &xr, data, order));
                }
            }
            // Next cube corner in the box of candidates.
            let mut axis = 0;
            while axis < s && z[axis] == ranges[axis].1 {
                z[axis] = ranges[axis].0;
                axis += 1;
            }
            if axis == s {
                break;
            }
            z[axis] += 1;
        }
        if out.is_empty() {
            out.push(self.eval_f64_order(x, data, order));
        }
        out
    }

    /// The polynomial of `cell` (in the cube moved by the lattice vector `l`)
    /// at xr = x - l, extrapolated when xr is outside the cell: value, ∂/∂x
    /// and ∂²/∂x².
    fn eval_f64_in_cell(
        &self,
        cell: usize,
        l: &[i64],
        xr: &[f64],
        data: &dyn Fn(&[i64]) -> f64,
        order: usize,
    ) -> SecondOrder {
        let t = self.f64_tables();
        let s = xr.len();
        let map = &self.maps[cell];
        let r = &self.references[map.reference];
        let y: Vec<f64> = (0..s)
            .map(|i| {
                map.rotation[i].iter().zip(xr).map(|(a, b)| *a as f64 * b).sum::<f64>() + map.translation[i] as f64
            })
            .collect();
        let u: Vec<f64> = (0..s).map(|i| y[i] - t.offset[i] - r.corner[i] as f64).collect();
        let tab = self.f64_reference(map.reference);
        let mut combined = vec![0.0; tab.exps.len()];
        for (k, off) in r.stencil.iter().enumerate() {
            let j = add_i(l, &map.inverse_point(&add_i(&r.corner, off)));
            let c = data(&j);
            if c == 0.0 {
                continue;
            }
            for (acc, coef) in combined.iter_mut().zip(&tab.coeffs[k]) {
                *acc += c * coef;
            }
        }
        let (value, grad_u, hess_u) = if order >= 2 {
            eval_poly_f64_hessian(&tab.exps, &combined, &u)
        } else {
            let (v, g) = eval_poly_f64(&tab.exps, &combined, &u);
            (v, g, vec![])
        };
        let rot = |k: usize, i: usize| map.rotation[k][i] as f64;
        let grad: Vec<f64> = (0..s).map(|i| (0..s).map(|k| rot(k, i) * grad_u[k]).sum()).collect();
        // y = R x + t: H_x = R^T H_u R.
        let hess: Vec<f64> = (0..if order >= 2 { s * s } else { 0 })
            .map(|ij| {
                let (i, j) = (ij / s, ij % s);
                (0..s)
                    .flat_map(|k| (0..s).map(move |m| (k, m)))
                    .map(|(k, m)| rot(k, i) * rot(m, j) * hess_u[k * s + m])
                    .sum()
            })
            .collect();
        (value, grad, hess)
    }
}
