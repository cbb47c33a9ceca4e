//! Evaluation of a spline with data on the lattice, through the reference
//! pieces and the maps g: the path the shaders take (locate the cube and
//! cell, map to the reference piece, fetch at g^-1(k), evaluate the
//! reference polynomials). Exact (rationals) and f64.

use crate::derive::Derivation;
use crate::exact::Q;
use crate::linalg::{add_i, sub_q, to_q, IVec, QVec};

/// Where a point falls: its cell (in the representative cube) and the
/// lattice vector l that moves the representative cube onto the point's cube.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Location {
    pub cell: usize,
    pub lattice_shift: IVec,
}

impl Derivation {
    /// Finds the cell containing x (any containing cell on boundaries).
    pub fn locate(&self, x: &[Q]) -> Location {
        let arr = &self.arrangement;
        let z: IVec = x.iter().zip(&arr.grid_offset).map(|(a, o)| (a - o).floor_i64().expect("finite point")).collect();
        let (ci, l) = arr.locate_cube(&self.filter.lattice, &z);
        let xr = sub_q(x, &to_q(&l));
        let cell = arr
            .cells
            .iter()
            .enumerate()
            .find(|(_, c)| c.class == ci && c.polytope.contains(&xr))
            .map(|(i, _)| i)
            .expect("cells cover the cube");
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
            .expect("cells cover the cube")
            .0;
        let map = &self.maps[cell];
        let r = &self.references[map.reference];
        let y: Vec<f64> = (0..s)
            .map(|i| {
                map.rotation[i].iter().zip(&xr).map(|(a, b)| *a as f64 * b).sum::<f64>() + map.translation[i] as f64
            })
            .collect();
        let u: Vec<f64> = (0..s).map(|i| y[i] - t.offset[i] - r.corner[i] as f64).collect();
        let tab = self.f64_reference(map.reference);
        // Sum the data-weighted coefficients first, then evaluate one polynomial.
        let mut combined = vec![0.0; tab.exps.len()];
        for (k, off) in r.stencil.iter().enumerate() {
            let j = add_i(&l, &map.inverse_point(&add_i(&r.corner, off)));
            let c = data(&j);
            if c == 0.0 {
                continue;
            }
            for (acc, coef) in combined.iter_mut().zip(&tab.coeffs[k]) {
                *acc += c * coef;
            }
        }
        let (value, grad_u) = eval_poly_f64(&tab.exps, &combined, &u);
        // d/dx = R^T d/dy
        let grad: Vec<f64> = (0..s).map(|i| (0..s).map(|k| map.rotation[k][i] as f64 * grad_u[k]).sum()).collect();
        (value, grad)
    }
}

/// Value and gradient of sum c_e u^e.
pub(crate) fn eval_poly_f64(exps: &[Vec<u32>], coeffs: &[f64], u: &[f64]) -> (f64, Vec<f64>) {
    let s = u.len();
    let mut v = 0.0;
    let mut g = vec![0.0; s];
    for (e, &c) in exps.iter().zip(coeffs) {
        if c == 0.0 {
            continue;
        }
        let mut m = c;
        for i in 0..s {
            m *= u[i].powi(e[i] as i32);
        }
        v += m;
        for d in 0..s {
            if e[d] == 0 {
                continue;
            }
            let mut md = c * e[d] as f64;
            for i in 0..s {
                let k = if i == d { e[i] - 1 } else { e[i] };
                md *= u[i].powi(k as i32);
            }
            g[d] += md;
        }
    }
    (v, g)
}

/// f64 copies of what evaluation needs.
#[derive(Clone, Debug)]
pub struct F64Tables {
    pub offset: Vec<f64>,
    /// Per cell: facets (normal, bound).
    pub cells: Vec<Vec<(Vec<f64>, f64)>>,
    /// Per reference piece, filled on first use.
    pub references: Vec<std::sync::OnceLock<F64Reference>>,
}

#[derive(Clone, Debug)]
pub struct F64Reference {
    pub exps: Vec<Vec<u32>>,
    /// Per stencil sample: coefficients in `exps` order.
    pub coeffs: Vec<Vec<f64>>,
}

impl Derivation {
    pub fn f64_tables(&self) -> &F64Tables {
        self.f64_cache.get_or_init(|| F64Tables {
            offset: self.arrangement.grid_offset.iter().map(|q| q.to_f64()).collect(),
            cells: self
                .arrangement
                .cells
                .iter()
                .map(|c| {
                    c.polytope
                        .facets
                        .iter()
                        .map(|h| (h.normal.iter().map(|q| q.to_f64()).collect(), h.bound.to_f64()))
                        .collect()
                })
                .collect(),
            references: self.references.iter().map(|_| std::sync::OnceLock::new()).collect(),
        })
    }

    /// f64 coefficients of reference piece `ri`.
    pub fn f64_reference(&self, ri: usize) -> &F64Reference {
        self.f64_tables().references[ri].get_or_init(|| {
            let polys = &self.forms(ri).polys;
            F64Reference {
                exps: polys.first().map(|p| p.basis.exps.clone()).unwrap_or_default(),
                coeffs: polys.iter().map(|p| p.coeffs.iter().map(|c| c.to_f64()).collect()).collect(),
            }
        })
    }
}
