//! The inspect report: one serialisable value per filter (JSON) and a
//! readable text rendering of it.

use crate::derive::arrangement::KnotFamily;
use crate::derive::Derivation;
use crate::math::exact::Q;
use crate::math::linalg::{IVec, QVec};
use crate::validate::Binding;
use serde::Serialize;
use std::fmt::Write;

/// What a filter's continuity means for its derivatives, in one sentence:
/// where the gradient and the Hessian (`<f>_eval_hessian`, curvature) are
/// continuous across knot planes and where they jump.
pub fn smoothness(continuity: i64, degree: usize) -> String {
    match continuity {
        k if k >= 2 => {
            format!("C^{k} across knot planes: value, gradient and Hessian are continuous (curvature is smooth).")
        }
        1 => "C^1 across knot planes: value and gradient are continuous; the Hessian jumps across knot planes \
              (curvature is piecewise, discontinuous at the planes)."
            .into(),
        0 if degree >= 2 => "C^0 across knot planes: the gradient and the Hessian jump across knot planes.".into(),
        0 => "C^0 across knot planes: the gradient jumps across knot planes; pieces are linear, so there is no \
              eval_hessian (zero inside every cell)."
            .into(),
        _ => "discontinuous across knot planes.".into(),
    }
}

/// The version of the JSON layout of [`Report`]: raise it whenever a key is
/// added, removed, renamed or changes meaning, so that readers of the
/// checked-in reports can tell (a test pins the keys to this number).
///
/// 2: `schema_version` itself and a `bindings` table per shader module.
/// 3: `ops_eval_hessian` and `hessian_form` per shader module (null below degree 2).
pub const REPORT_SCHEMA_VERSION: u32 = 3;

/// Everything `inspect` shows about one filter and `generate` writes next to its shaders.
#[derive(Serialize)]
pub struct Report {
    /// The JSON layout's version, [`REPORT_SCHEMA_VERSION`].
    pub schema_version: u32,
    /// Filter name (the prefix of the WGSL identifiers).
    pub name: String,
    /// Free-text description from the spec.
    pub description: String,
    /// Dimension s of the lattice and the directions.
    pub dimension: usize,
    /// Lattice name: a built-in name or `custom`.
    pub lattice: String,
    /// Generator columns of the lattice, as given.
    pub lattice_generators: Vec<IVec>,
    /// |det G|: integer points per lattice point.
    pub lattice_det: i64,
    /// The direction vectors, as given.
    pub directions: Vec<IVec>,
    /// Polynomial degree of the pieces: directions minus dimension.
    pub degree: usize,
    /// Approximation order: the fewest directions off any knot hyperplane.
    pub approximation_order: usize,
    /// Continuity C^k: approximation order - 2; -1 means discontinuous.
    pub continuity: i64,
    /// Volume of the support: the sum of |det| over every s-subset of directions.
    pub support_volume: i64,
    /// The knot-plane families n . x in offset + period Z.
    pub knot_planes: Vec<KnotFamily>,
    /// Grid offset o: the cubes are o + z + `[0,1]^s`.
    pub grid_offset: QVec,
    /// Number of cube classes (classes of Z^s / L, i.e. |det G|).
    pub cube_classes: usize,
    /// Integer lower corner z of each class's representative cube.
    pub cube_class_corners: Vec<IVec>,
    /// Number of cells the knot planes cut the representative cubes into.
    pub cells_per_fundamental_domain: usize,
    /// Regions of the knot-plane arrangement alone per fundamental domain
    /// (cells merged across grid faces that are not knot planes).
    pub polynomial_pieces_per_fundamental_domain: usize,
    /// Order of the symmetry group used to fold cells onto reference pieces.
    pub symmetry_order: usize,
    /// One entry per orbit of cells under the symmetry group.
    pub reference_pieces: Vec<ReferenceReport>,
    /// Largest stencil (samples per evaluation) of any reference piece.
    pub max_stencil_size: usize,
    /// The non-zero quasi-interpolation prefilter weights, by lattice point.
    pub prefilter: Vec<Weight>,
    /// Shells (orbits, origin included) the prefilter needed.
    pub prefilter_shells: usize,
    /// Every evaluation cell with its map onto its reference piece.
    pub cells: Vec<CellReport>,
    /// How the fast shaders locate points, and their fetch order.
    pub evaluation: EvaluationReport,
    /// Counts and bindings of the emitted shaders (filled by `generate`).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub shaders: Vec<ShaderReport>,
    /// Hardware-filtered fetches, where the filter allows them.
    pub linear_fetch: Option<LinearFetchReport>,
    /// Hardware-filtered fetches on the packed layout (pairs per coset).
    pub linear_fetch_packed: Option<PackedLinearFetchReport>,
    /// The size of the derivation: the estimate it was admitted on, and the
    /// polynomials it derived.
    pub work: WorkReport,
    /// Seconds the derivation took (filled by `inspect`; left out of the
    /// files `generate` writes, which must be the same bytes every run).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub derivation_seconds: Option<f64>,
}

/// One emitted module in the report: its counts and the bindings it declares.
#[derive(Clone, Debug, Serialize)]
pub struct ShaderReport {
    /// The emitter's counts (their keys sit at the top level of the JSON object).
    #[serde(flatten)]
    pub stats: crate::emit::EmitStats,
    /// Every binding the module declares, read from the validated module
    /// (see [`module_bindings`]).
    pub bindings: Vec<Binding>,
}

/// The bindings of an emitted module of filter `filter`, read from its
/// validated naga module, each with the hand-written purpose of its name
/// ([`crate::emit::binding_purpose`]).
///
/// # Errors
///
/// [`crate::Error::Unsupported`] naming the module when the source does not
/// validate (an emitter bug: every emitted module must validate).
pub fn module_bindings(filter: &str, file_name: &str, source: &str) -> crate::Result<Vec<Binding>> {
    let mut bindings = crate::validate::bindings_of_wgsl(source).map_err(|message| crate::Error::Unsupported {
        origin: format!("module {file_name}"),
        message: format!("the emitted WGSL does not validate: {message}"),
    })?;
    for b in &mut bindings {
        b.purpose = crate::emit::binding_purpose(filter, &b.name).map(str::to_string);
    }
    Ok(bindings)
}

/// Reports list every piece's BB and power coefficients up to this many
/// polynomials; beyond it the JSON would run to hundreds of megabytes.
pub const DETAIL_LIMIT_POLYNOMIALS: usize = 4096;

/// What [`Report::with_options`] lists.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ReportOptions {
    /// List every piece's BB and power coefficients whatever the size (a
    /// caller that wants them all, e.g. for an offline check, accepts the
    /// size of the JSON). Off by default.
    pub all_coefficients: bool,
    /// Without `all_coefficients`, coefficients are listed up to this many
    /// polynomials (default [`DETAIL_LIMIT_POLYNOMIALS`]).
    pub detail_limit: usize,
}

impl Default for ReportOptions {
    fn default() -> Self {
        ReportOptions { all_coefficients: false, detail_limit: DETAIL_LIMIT_POLYNOMIALS }
    }
}

impl ReportOptions {
    /// Every coefficient listed, however many polynomials.
    pub fn all_coefficients() -> Self {
        ReportOptions { all_coefficients: true, ..ReportOptions::default() }
    }

    /// Whether a derivation with `polynomials` polynomials has its coefficients listed.
    pub fn lists_coefficients(&self, polynomials: usize) -> bool {
        self.all_coefficients || polynomials <= self.detail_limit
    }
}

/// How big the derivation was expected to be and was.
#[derive(Clone, Debug, Serialize)]
pub struct WorkReport {
    /// The estimate the derivation was admitted on (before the cells were cut).
    pub estimate: crate::derive::Estimate,
    /// Reference pieces x their stencils, as derived.
    pub polynomials: usize,
    /// Whether BB and power coefficients are listed (see [`ReportOptions`]).
    pub coefficients_listed: bool,
}

mod linear;
mod text;

use linear::{linear_fetch_report, packed_linear_fetch_report};
pub use linear::{LinearFetchReport, PackedLinearFetchReport};

/// How the fast shader locates a point and what one evaluation costs.
#[derive(Serialize)]
pub struct EvaluationReport {
    /// The plan's [`Locate`](crate::emit::plan::Locate), in `Debug` form.
    pub locate: String,
    /// Number of candidate cells tested after locating the frame.
    pub candidates: usize,
    /// Exact samples fetched per evaluation.
    pub fetches_per_eval: usize,
    /// Vector adds to walk the fetch positions in axis-aligned order.
    pub vector_adds: usize,
    /// Adds a plain matrix-vector product per fetch would cost instead.
    pub matvec_adds: usize,
    /// Fetch offsets q (x = b + M q, see `plan`) of the first candidate, in fetch order.
    pub fetch_order: Vec<IVec>,
}

/// One exact weight at a lattice offset (a prefilter tap or a BB weight).
#[derive(Serialize)]
pub struct Weight {
    /// Lattice offset: the point j of a prefilter tap, or the stencil offset
    /// (relative to the piece's corner) of a BB weight.
    pub offset: IVec,
    /// The exact weight.
    pub w: Q,
}

/// One BB coefficient as a weighted sum of stencil samples.
#[derive(Serialize)]
pub struct BbCoefficient {
    /// Multi-index alpha (|alpha| = degree, s + 1 entries).
    pub index: Vec<u32>,
    /// Non-zero weights of the stencil samples, by stencil offset.
    pub weights: Vec<Weight>,
}

/// One term c * u^exponent of a power-form polynomial.
#[derive(Serialize)]
pub struct Monomial {
    /// Exponent e, one entry per coordinate of u.
    pub exponent: Vec<u32>,
    /// The exact coefficient c.
    pub c: Q,
}

/// The power-form polynomial of one stencil offset.
#[derive(Serialize)]
pub struct PowerPiece {
    /// Stencil offset k (relative to the piece's corner).
    pub offset: IVec,
    /// Non-zero terms of the polynomial.
    pub terms: Vec<Monomial>,
}

/// One reference piece: its cell, stencil and exact forms.
#[derive(Serialize)]
pub struct ReferenceReport {
    /// Integer lower corner z of its cube (the cube is o + z + `[0,1]^s`).
    pub corner: IVec,
    /// Vertices of the cell, in global coordinates.
    pub vertices: Vec<QVec>,
    /// Whether the cell is a simplex (and so has a BB form).
    pub is_simplex: bool,
    /// Number of cells mapped onto this piece.
    pub cells_in_orbit: usize,
    /// Lattice points relative to `corner` whose basis function is non-zero here.
    pub stencil: Vec<IVec>,
    /// BB coefficients; empty for non-simplicial pieces or when coefficients are not listed.
    pub bb: Vec<BbCoefficient>,
    /// Power form in local coordinates u = x - o - corner, per stencil offset.
    pub power: Vec<PowerPiece>,
}

/// One evaluation cell and its map onto its reference piece.
#[derive(Serialize)]
pub struct CellReport {
    /// Index into `cube_class_corners`.
    pub class: usize,
    /// Vertices of the cell, in global coordinates.
    pub vertices: Vec<QVec>,
    /// Index into `reference_pieces`.
    pub reference: usize,
    /// Rows of the signed permutation R of g(x) = R x + t.
    pub rotation: Vec<IVec>,
    /// The integer translation t of g(x) = R x + t.
    pub translation: IVec,
}

impl Report {
    /// Collects the report from a derivation (coefficients only up to [`DETAIL_LIMIT_POLYNOMIALS`]).
    pub fn new(d: &Derivation) -> Report {
        Report::with_options(d, &ReportOptions::default())
    }

    /// Collects the report from a derivation, listing coefficients as `opts` says.
    pub fn with_options(d: &Derivation, opts: &ReportOptions) -> Report {
        let f = &d.filter;
        let arr = &d.arrangement;
        let polynomials = d.polynomials();
        let detailed = opts.lists_coefficients(polynomials);
        let plan = crate::emit::plan::Plan::new(d);
        Report {
            schema_version: REPORT_SCHEMA_VERSION,
            name: f.name.clone(),
            description: f.description.clone(),
            dimension: f.dim(),
            lattice: f.lattice.name.clone(),
            lattice_generators: f.lattice.generators.clone(),
            lattice_det: f.lattice.det(),
            directions: f.directions.clone(),
            degree: d.facts.degree,
            approximation_order: d.facts.approximation_order,
            continuity: d.facts.continuity,
            support_volume: d.facts.support_volume,
            knot_planes: arr.families.clone(),
            grid_offset: arr.grid_offset.clone(),
            cube_classes: arr.classes.len(),
            cube_class_corners: arr.classes.clone(),
            cells_per_fundamental_domain: arr.cells.len(),
            polynomial_pieces_per_fundamental_domain: arr.pieces_per_fundamental_domain,
            symmetry_order: d.group.len(),
            reference_pieces: d
                .references
                .iter()
                .enumerate()
                .map(|(ri, r)| ReferenceReport {
                    corner: r.corner.clone(),
                    vertices: r.vertices.clone(),
                    is_simplex: r.is_simplex,
                    cells_in_orbit: d.maps.iter().filter(|m| m.reference == ri).count(),
                    stencil: r.stencil.clone(),
                    bb: (if detailed { d.forms(ri).bb.as_ref() } else { None })
                        .map(|bb| {
                            bb.indices
                                .iter()
                                .zip(&bb.weights)
                                .map(|(a, ws)| BbCoefficient {
                                    index: a.clone(),
                                    weights: r
                                        .stencil
                                        .iter()
                                        .zip(ws)
                                        .filter(|(_, w)| !w.is_zero())
                                        .map(|(k, w)| Weight { offset: k.clone(), w: w.clone() })
                                        .collect(),
                                })
                                .collect()
                        })
                        .unwrap_or_default(),
                    power: r
                        .stencil
                        .iter()
                        .zip(if detailed { d.forms(ri).polys.as_slice() } else { &[] })
                        .map(|(k, p)| PowerPiece {
                            offset: k.clone(),
                            terms: p
                                .basis
                                .exps
                                .iter()
                                .zip(&p.coeffs)
                                .filter(|(_, c)| !c.is_zero())
                                .map(|(e, c)| Monomial { exponent: e.clone(), c: c.clone() })
                                .collect(),
                        })
                        .collect(),
                })
                .collect(),
            max_stencil_size: d.max_stencil(),
            prefilter: d.prefilter.taps.iter().map(|(j, w)| Weight { offset: j.clone(), w: w.clone() }).collect(),
            prefilter_shells: d.prefilter.shells,
            evaluation: {
                EvaluationReport {
                    locate: format!("{:?}", plan.locate),
                    candidates: plan.candidates.len(),
                    fetches_per_eval: plan.fetches(),
                    vector_adds: plan.vector_adds,
                    matvec_adds: plan.matvec_adds,
                    fetch_order: plan.candidates[0].offsets.clone(),
                }
            },
            shaders: vec![],
            // Linear (hardware-filtered) fetches are a property of emitted
            // shaders; 4D filters are derived but not emitted, so none.
            linear_fetch: if f.dim() <= 3 { linear_fetch_report(d) } else { None },
            linear_fetch_packed: if f.dim() <= 3 { packed_linear_fetch_report(d, &plan) } else { None },
            work: WorkReport { estimate: d.estimate, polynomials, coefficients_listed: detailed },
            derivation_seconds: None,
            cells: arr
                .cells
                .iter()
                .zip(&d.maps)
                .map(|(c, m)| CellReport {
                    class: c.class,
                    vertices: c.polytope.vertices.clone(),
                    reference: m.reference,
                    rotation: m.rotation.clone(),
                    translation: m.translation.clone(),
                })
                .collect(),
        }
    }

    /// Deterministic compact JSON (pretty printing makes bcc12 megabytes).
    pub fn to_json(&self) -> String {
        serde_json::to_string(self).expect(
            "the report is plain data (strings, numbers, vectors, no maps with non-string keys): it always serialises",
        )
    }

    /// JSON with a leading `generated_by` key naming the command.
    pub fn to_json_with_header(&self, command: &str) -> String {
        let body = self.to_json();
        format!(
            "{{\"generated_by\":{},{}",
            serde_json::to_string(command).expect("a string always serialises to JSON"),
            &body[1..]
        )
    }
}

#[cfg(test)]
mod tests;
