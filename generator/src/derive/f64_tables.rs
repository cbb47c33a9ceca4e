//! f64 copies of the exact derivation (cell facets, grid offset, reference
//! polynomial coefficients), built lazily by the derivation that owns them so
//! that the f64 evaluator and the runtime read them without re-deriving.

use crate::derive::Derivation;

/// f64 copies of what evaluation needs.
#[derive(Clone, Debug)]
pub struct F64Tables {
    /// The grid offset o, in f64.
    pub offset: Vec<f64>,
    /// Per cell: facets (normal, bound).
    pub cells: Vec<Vec<(Vec<f64>, f64)>>,
    /// Per reference piece, filled on first use.
    pub references: Vec<std::sync::OnceLock<F64Reference>>,
}

/// f64 copy of one reference piece's polynomials (one per stencil sample).
#[derive(Clone, Debug)]
pub struct F64Reference {
    /// Monomial exponents shared by every polynomial of the piece.
    pub exps: Vec<Vec<u32>>,
    /// Per stencil sample: coefficients in `exps` order.
    pub coeffs: Vec<Vec<f64>>,
}

impl Derivation {
    /// The f64 tables, built on first use.
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
