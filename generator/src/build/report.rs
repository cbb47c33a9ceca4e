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

/// Precision of `fetch = linear` (Sigg & Hadwiger's scheme, derived): the
/// CPU emulation of the hardware's interpolation, exact and with weights
/// rounded to 8 fractional bits (CUDA documents 9-bit fixed point with 8
/// fractional bits; lavapipe filters in float), at seeded random points on
/// random data in [0, 1].
#[derive(Clone, Debug, Serialize)]
pub struct LinearFetchReport {
    /// Hardware-filtered fetches per evaluation: ceil(n_i / 2) per axis.
    pub fetches: usize,
    /// Exact loads per evaluation the filtered fetches replace.
    pub exact_loads: usize,
    /// Number of seeded random points the errors are measured at.
    pub points: usize,
    /// Largest absolute error against the exact evaluator with unrounded weights.
    pub max_error_float_weights: f64,
    /// Largest absolute error with weights rounded to 8 fractional bits.
    pub max_error_8bit_weights: f64,
    /// RMS error with weights rounded to 8 fractional bits.
    pub rms_error_8bit_weights: f64,
}

/// Precision of `fetch = linear` on the packed layout (every filter whose
/// stencil has samples adjacent in a coset grid): pairs per coset, the
/// exact evidence that their weights are non-negative, and the CPU
/// emulation of the interpolation as for [`LinearFetchReport`].
#[derive(Clone, Debug, Serialize)]
pub struct PackedLinearFetchReport {
    /// Hardware-filtered fetches per evaluation: the most any used reference needs.
    pub fetches: usize,
    /// Exact loads per evaluation (the plan's fetches) they replace.
    pub exact_loads: usize,
    /// How the non-negativity of every fetch weight was established.
    pub non_negative: crate::emit::linear::NonNegativity,
    /// Number of seeded random points the errors are measured at.
    pub points: usize,
    /// Largest absolute error against the exact evaluator with unrounded weights.
    pub max_error_float_weights: f64,
    /// Largest absolute error with weights rounded to 8 fractional bits.
    pub max_error_8bit_weights: f64,
    /// RMS error with weights rounded to 8 fractional bits.
    pub rms_error_8bit_weights: f64,
}

/// Deterministic numbers in [0, 1) (SplitMix64 of the input).
fn hash01(mut z: u64) -> f64 {
    z = z.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    (z ^ (z >> 31)) as f64 / u64::MAX as f64
}

/// Random data in [0, 1) per lattice point.
fn hashed_data(j: &[i64]) -> f64 {
    hash01(j.iter().fold(17u64, |h, &x| h.wrapping_mul(1_000_003).wrapping_add(x as u64)))
}

const PRECISION_POINTS: usize = 2000;

/// (max error with float weights, max and RMS error with 8-bit weights) of
/// `linear(x, frac_bits)` against the exact evaluator at seeded points.
fn linear_errors(d: &Derivation, linear: &dyn Fn(&[f64], Option<u32>) -> f64) -> (f64, f64, f64) {
    let s = d.facts.dim;
    let (mut max_f, mut max_8, mut sum2) = (0f64, 0f64, 0f64);
    for i in 0..PRECISION_POINTS {
        let x: Vec<f64> = (0..s).map(|c| 20.0 * hash01((i * 7 + c) as u64)).collect();
        let exact = d.eval_f64(&x, &hashed_data).0;
        max_f = max_f.max((linear(&x, None) - exact).abs());
        let e8 = (linear(&x, Some(8)) - exact).abs();
        max_8 = max_8.max(e8);
        sum2 += e8 * e8;
    }
    (max_f, max_8, (sum2 / PRECISION_POINTS as f64).sqrt())
}

fn linear_fetch_report(d: &Derivation) -> Option<LinearFetchReport> {
    let fac = d.factorisation()?;
    if !fac.supports_linear_fetch() {
        return None;
    }
    let (max_f, max_8, rms) = linear_errors(d, &|x, bits| fac.eval_linear_f64(x, &hashed_data, bits));
    Some(LinearFetchReport {
        fetches: fac.linear_fetches(),
        exact_loads: fac.fetches(),
        points: PRECISION_POINTS,
        max_error_float_weights: max_f,
        max_error_8bit_weights: max_8,
        rms_error_8bit_weights: rms,
    })
}

fn packed_linear_fetch_report(d: &Derivation, plan: &crate::emit::plan::Plan) -> Option<PackedLinearFetchReport> {
    crate::emit::coset_pivots(&d.filter.lattice).ok()?;
    let lin = crate::emit::linear::LinearPlan::new(d);
    if lin.fetches(plan) >= plan.fetches() {
        return None;
    }
    let (max_f, max_8, rms) = linear_errors(d, &|x, bits| lin.eval_f64(d, plan, x, &hashed_data, bits));
    Some(PackedLinearFetchReport {
        fetches: lin.fetches(plan),
        exact_loads: plan.fetches(),
        non_negative: lin.proof.clone(),
        points: PRECISION_POINTS,
        max_error_float_weights: max_f,
        max_error_8bit_weights: max_8,
        rms_error_8bit_weights: rms,
    })
}

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

    /// A Markdown rendering for humans (checked into shaders-out/).
    pub fn to_markdown(&self) -> String {
        let mut s = String::new();
        let v = |q: &QVec| format!("({})", q.iter().map(|x| x.to_string()).collect::<Vec<_>>().join(", "));
        let iv = |q: &IVec| format!("({})", q.iter().map(|x| x.to_string()).collect::<Vec<_>>().join(", "));
        let _ = writeln!(s, "# {}\n\n{}\n", self.name, self.description);
        let _ = writeln!(s, "| fact | value |\n|---|---|");
        let rows = [
            (
                "lattice",
                format!(
                    "{} (generators {}, \\|det G\\| = {})",
                    self.lattice,
                    self.lattice_generators.iter().map(iv).collect::<Vec<_>>().join(" "),
                    self.lattice_det
                ),
            ),
            ("directions", self.directions.iter().map(iv).collect::<Vec<_>>().join(" ")),
            ("degree", self.degree.to_string()),
            ("approximation order", self.approximation_order.to_string()),
            ("continuity", format!("C^{}", self.continuity)),
            ("smoothness", smoothness(self.continuity, self.degree)),
            ("support volume", self.support_volume.to_string()),
            ("grid offset", v(&self.grid_offset)),
            (
                "cube classes",
                format!(
                    "{}: {}",
                    self.cube_classes,
                    self.cube_class_corners.iter().map(iv).collect::<Vec<_>>().join(" ")
                ),
            ),
            ("evaluation cells per fundamental domain", self.cells_per_fundamental_domain.to_string()),
            ("polynomial pieces per fundamental domain", self.polynomial_pieces_per_fundamental_domain.to_string()),
            ("symmetry order", self.symmetry_order.to_string()),
            ("reference pieces", self.reference_pieces.len().to_string()),
            ("max stencil", self.max_stencil_size.to_string()),
            (
                "polynomials (reference pieces x stencil)",
                format!(
                    "{} (estimated {} before cutting: {} reference pieces x {} mean stencil){}",
                    self.work.polynomials,
                    self.work.estimate.polynomials,
                    self.work.estimate.reference_pieces,
                    self.work.estimate.stencil,
                    if self.work.coefficients_listed {
                        ""
                    } else {
                        "; coefficients not listed (over the report limit)"
                    }
                ),
            ),
        ];
        for (k, val) in rows {
            let _ = writeln!(s, "| {k} | {val} |");
        }
        let _ = writeln!(s, "\n## Knot planes\n\n| normal n | n.x in |\n|---|---|");
        for k in &self.knot_planes {
            let _ = writeln!(s, "| {} | {} + {}Z |", iv(&k.normal), k.offset, k.period);
        }
        let _ = writeln!(s, "\n## Cells and their maps g(x) = R x + t onto reference pieces\n");
        let _ = writeln!(s, "| cell | class | vertices | reference | R (rows) | t |\n|---|---|---|---|---|---|");
        for (i, c) in self.cells.iter().enumerate().take(200) {
            let _ = writeln!(
                s,
                "| {i} | {} | {} | {} | {} | {} |",
                c.class,
                c.vertices.iter().map(v).collect::<Vec<_>>().join(" "),
                c.reference,
                c.rotation.iter().map(iv).collect::<Vec<_>>().join(" "),
                iv(&c.translation)
            );
        }
        if self.cells.len() > 200 {
            let _ = writeln!(s, "\n({} more cells in the JSON report)", self.cells.len() - 200);
        }
        for (i, r) in self.reference_pieces.iter().enumerate() {
            let _ = writeln!(s, "\n## Reference piece {i}\n");
            let _ = writeln!(
                s,
                "{} in the cube with corner {}, orbit of {} cells.\n\nVertices: {}\n",
                if r.is_simplex { "Simplex" } else { "Polytope" },
                iv(&r.corner),
                r.cells_in_orbit,
                r.vertices.iter().map(v).collect::<Vec<_>>().join(" ")
            );
            let _ = writeln!(s, "Stencil ({} samples, offsets from the cube corner):\n", r.stencil.len());
            for k in &r.stencil {
                let _ = writeln!(s, "- {}", iv(k));
            }
            if r.is_simplex {
                let _ = writeln!(s, "\nBB coefficients b_alpha = sum w c(offset):\n\n| alpha | weights |\n|---|---|");
                for b in &r.bb {
                    let ws: Vec<String> = b.weights.iter().map(|w| format!("{} c{}", w.w, iv(&w.offset))).collect();
                    let idx: Vec<String> = b.index.iter().map(|x| x.to_string()).collect();
                    let _ = writeln!(s, "| {} | {} |", idx.join(""), ws.join(" + "));
                }
            } else {
                let _ = writeln!(s, "\nNot a simplex: the power form (in the JSON report) is used.");
            }
        }
        let e = &self.evaluation;
        let _ = writeln!(
            s,
            "\n## Evaluation in the shaders\n\nPoint location: {}, {} candidate cell(s) after locating. {} fetches per evaluation; {} vector adds walk the fetch positions (a matrix-vector product per fetch would cost {}).\n\nFetch order (offsets q from the frame base, x = b + M q):\n",
            e.locate, e.candidates, e.fetches_per_eval, e.vector_adds, e.matvec_adds
        );
        let _ = writeln!(s, "{}", e.fetch_order.iter().map(iv).collect::<Vec<_>>().join(" → "));
        if !self.shaders.is_empty() {
            let _ = writeln!(s, "\n| layout | variant | form | fetches/eval | vector adds | ops in eval | ops in eval_grad | eval_hessian form | ops in eval_hessian |\n|---|---|---|---|---|---|---|---|---|");
            for st in self.shaders.iter().map(|sr| &sr.stats) {
                let _ = writeln!(
                    s,
                    "| {} | {} | {} | {} | {} | {} | {} | {} | {} |",
                    st.layout.name(),
                    st.variant.name(),
                    st.form.name(),
                    st.fetches_per_eval,
                    st.vector_adds,
                    st.ops_eval,
                    st.ops_eval_grad,
                    st.hessian_form.map_or("none", |f| f.name()),
                    st.ops_eval_hessian.map_or("-".to_string(), |n| n.to_string())
                );
            }
            let _ = writeln!(s, "\n(ops: operators, comparisons, selects and builtin calls in the WGSL source; the naive variant's loops are counted once. The naive variant keeps the dense form: it measures branches and lookup tables.)");
            if let Some(st) = self.shaders.iter().map(|sr| &sr.stats).find(|st| st.variant.name() == "fast") {
                let _ = writeln!(
                    s,
                    "\n### Evaluation forms\n\nThe generator emits every exact form available for this filter and keeps the cheapest by its cost model (ops in eval + ops in eval_grad; exact loads are the same for every form). Chosen: **{}**.\n\n| form | fetches | ops in eval | ops in eval_grad | cost |\n|---|---|---|---|---|",
                    st.form.name()
                );
                for f in &st.forms {
                    let _ = writeln!(
                        s,
                        "| {} | {} | {} | {} | {} |",
                        f.form.name(),
                        f.fetches,
                        f.ops_eval,
                        f.ops_eval_grad,
                        f.cost()
                    );
                }
            }
        }
        if !self.shaders.is_empty() {
            let _ = writeln!(
                s,
                "\n### Bindings\n\nRead from each validated module (naga). Used by: entry points, and the functions no other function calls (the module's API).\n\n| layout | variant | fetch | group | binding | name | kind | format | used by | host puts there |\n|---|---|---|---|---|---|---|---|---|---|"
            );
            for sr in &self.shaders {
                for b in &sr.bindings {
                    let used: Vec<&str> = b.entry_points.iter().chain(&b.functions).map(String::as_str).collect();
                    let _ = writeln!(
                        s,
                        "| {} | {} | {} | {} | {} | `{}` | `{}` | {} | {} | {} |",
                        sr.stats.layout.name(),
                        sr.stats.variant.name(),
                        sr.stats.fetch.name(),
                        b.group,
                        b.binding,
                        b.name,
                        b.kind,
                        b.format.as_ref().map(|f| format!("`{f}`")).unwrap_or_else(|| "-".into()),
                        if used.is_empty() { "-".to_string() } else { used.join(", ") },
                        b.purpose.as_deref().unwrap_or("-")
                    );
                }
            }
        }
        if let Some(l) = &self.linear_fetch {
            let _ = writeln!(
                s,
                "\n### Linear fetches\n\n`fetch = linear` (Builder::fetch): {} hardware-filtered fetches instead of {} exact loads in eval. CPU emulation of the hardware interpolation at {} random points on random data in [0, 1]: max error {:.1e} with float weights (lavapipe), {:.1e} (RMS {:.1e}) with weights rounded to 8 fractional bits (typical GPU texture units).",
                l.fetches, l.exact_loads, l.points, l.max_error_float_weights, l.max_error_8bit_weights, l.rms_error_8bit_weights
            );
        }
        if let Some(l) = &self.linear_fetch_packed {
            let p = &l.non_negative;
            let _ = writeln!(
                s,
                "\n### Linear fetches, packed layout\n\n`fetch = linear` with `layout = packed`: {} hardware-filtered fetches instead of {} exact loads in eval (pairs of samples adjacent in one coset's grid, a maximum matching per reference piece). Weights non-negative: {} of {} by their Bernstein-Bezier coefficients (exact), {} by the box-spline theorem. CPU emulation at {} random points on random data in [0, 1]: max error {:.1e} with float weights (lavapipe), {:.1e} (RMS {:.1e}) with weights rounded to 8 fractional bits.",
                l.fetches, l.exact_loads, p.by_bernstein_coefficients, p.weights, p.by_box_spline_theorem, l.points, l.max_error_float_weights, l.max_error_8bit_weights, l.rms_error_8bit_weights
            );
        }
        let _ = writeln!(
            s,
            "\n## Quasi-interpolation prefilter\n\n{} taps in {} shells.\n\n| offset | weight |\n|---|---|",
            self.prefilter.len(),
            self.prefilter_shells
        );
        for w in &self.prefilter {
            let _ = writeln!(s, "| {} | {} |", iv(&w.offset), w.w);
        }
        s
    }

    /// A readable summary for terminals.
    pub fn to_text(&self) -> String {
        let mut s = String::new();
        let v = |q: &QVec| format!("({})", q.iter().map(|x| x.to_string()).collect::<Vec<_>>().join(", "));
        let iv = |q: &IVec| format!("({})", q.iter().map(|x| x.to_string()).collect::<Vec<_>>().join(", "));
        let _ = writeln!(s, "{} — {}", self.name, self.description);
        let _ = writeln!(
            s,
            "  lattice           {} (|det G| = {}), dimension {}",
            self.lattice, self.lattice_det, self.dimension
        );
        let _ = writeln!(s, "  directions        {}", self.directions.iter().map(iv).collect::<Vec<_>>().join(" "));
        let _ = writeln!(
            s,
            "  degree {}, approximation order {}, continuity C^{}",
            self.degree, self.approximation_order, self.continuity
        );
        let _ = writeln!(s, "  smoothness        {}", smoothness(self.continuity, self.degree));
        let _ = writeln!(s, "  support volume    {}", self.support_volume);
        let _ = writeln!(s, "  knot planes       {} families:", self.knot_planes.len());
        for k in &self.knot_planes {
            let _ = writeln!(s, "    n = {:<14} n.x in {} + {}Z", iv(&k.normal), k.offset, k.period);
        }
        let _ = writeln!(s, "  grid offset       {}", v(&self.grid_offset));
        let _ = writeln!(
            s,
            "  cube classes      {}: {}",
            self.cube_classes,
            self.cube_class_corners.iter().map(iv).collect::<Vec<_>>().join(" ")
        );
        let _ = writeln!(s, "  evaluation cells  {} per fundamental domain", self.cells_per_fundamental_domain);
        let _ =
            writeln!(s, "  polynomial pieces {} per fundamental domain", self.polynomial_pieces_per_fundamental_domain);
        let _ = writeln!(s, "  symmetry order    {}", self.symmetry_order);
        let _ =
            writeln!(s, "  reference pieces  {} (max stencil {})", self.reference_pieces.len(), self.max_stencil_size);
        let _ = writeln!(
            s,
            "  polynomials       {} (estimated {} before cutting){}",
            self.work.polynomials,
            self.work.estimate.polynomials,
            self.derivation_seconds.map(|t| format!(", derived in {t:.2} s")).unwrap_or_default()
        );
        for (i, r) in self.reference_pieces.iter().enumerate().take(64) {
            let _ = writeln!(
                s,
                "    #{i}: {} with {} vertices in cube {}, orbit of {} cells, stencil {}, {}",
                if r.is_simplex { "simplex" } else { "polytope" },
                r.vertices.len(),
                iv(&r.corner),
                r.cells_in_orbit,
                r.stencil.len(),
                if r.is_simplex { format!("{} BB coefficients", r.bb.len()) } else { "power form".to_string() }
            );
            let _ = writeln!(s, "        vertices: {}", r.vertices.iter().map(v).collect::<Vec<_>>().join(" "));
        }
        if self.reference_pieces.len() > 64 {
            let _ = writeln!(s, "    ({} more in the JSON report)", self.reference_pieces.len() - 64);
        }
        let _ = writeln!(s, "  prefilter         {} taps in {} shells:", self.prefilter.len(), self.prefilter_shells);
        for w in &self.prefilter {
            let _ = writeln!(s, "    {} {}", iv(&w.offset), w.w);
        }
        s
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::spec::catalog;

    /// Smoothness classes derived from the direction matrices, against what
    /// the literature states: bcc7, bcc8 (Entezari et al.), bcc12 and
    /// cc_tricubic are C^2 (continuous Hessian); fcc6 (Kim et al. 2008), cc6
    /// (Kim & Kim 2023), the Zwart-Powell element and the triquadratic are C^1
    /// (the Hessian jumps); the linear and trilinear splines C^0. The
    /// markdown report says so in words.
    #[test]
    fn smoothness_classes_of_known_filters() {
        for (name, k) in [
            ("bcc7", 2),
            ("bcc8", 2),
            ("bcc12", 2),
            ("cc_tricubic", 2),
            ("fcc6", 1),
            ("cc6", 1),
            ("zp", 1),
            ("cc_triquadratic", 1),
            ("bcc_linear", 0),
            ("cc_trilinear", 0),
            ("courant", 0),
        ] {
            let d = Derivation::new(&catalog::get(name).unwrap()).unwrap();
            assert_eq!(d.facts.continuity, k, "{name}");
            let md = Report::new(&d).to_markdown();
            let line = smoothness(d.facts.continuity, d.facts.degree);
            assert!(md.contains(&line), "{name}: the report states its smoothness");
            assert_eq!(line.contains("Hessian are continuous"), k >= 2, "{name}: {line}");
            assert_eq!(line.contains("Hessian jumps"), k == 1, "{name}: {line}");
        }
    }

    #[test]
    fn all_coefficients_lists_them_past_the_limit() {
        let d = Derivation::new(&catalog::get("bcc_sheared_trilinear").unwrap()).unwrap();
        let counts = |r: &Report| -> (bool, usize, usize) {
            (
                r.work.coefficients_listed,
                r.reference_pieces.iter().map(|p| p.bb.len()).sum(),
                r.reference_pieces.iter().flat_map(|p| &p.power).map(|p| p.terms.len()).sum(),
            )
        };
        let limited = ReportOptions { detail_limit: d.polynomials() - 1, ..ReportOptions::default() };
        let (listed, bb, power) = counts(&Report::with_options(&d, &limited));
        assert_eq!((listed, bb, power), (false, 0, 0), "over the limit nothing is listed");
        let all = ReportOptions { all_coefficients: true, ..limited };
        let full = Report::with_options(&d, &all);
        let (listed, _, power) = counts(&full);
        assert!(listed && power > 0, "all_coefficients lists them past the limit");
        // Under the default limit this small filter lists the same coefficients.
        assert_eq!(full.to_json(), Report::new(&d).to_json());
        assert_eq!(ReportOptions::all_coefficients(), ReportOptions { all_coefficients: true, ..Default::default() });
        assert!(ReportOptions::default().lists_coefficients(DETAIL_LIMIT_POLYNOMIALS));
        assert!(!ReportOptions::default().lists_coefficients(DETAIL_LIMIT_POLYNOMIALS + 1));
    }

    #[test]
    fn unknown_names_have_no_purpose() {
        let b = module_bindings("zp", "x.wgsl", "@group(0) @binding(0) var<uniform> zp_other: vec4<f32>;").unwrap();
        assert_eq!(b.len(), 1);
        assert_eq!(b[0].purpose, None);
        assert!(module_bindings("zp", "x.wgsl", "not wgsl").is_err());
    }
}
