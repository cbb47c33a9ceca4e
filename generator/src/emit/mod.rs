//! WGSL emission: turns a [`Plan`] and the exact reference forms into a
//! module with `<f>_fetch`, `<f>_eval`, `<f>_eval_grad`, and the prefilter
//! and min/max kernels. Skeletons are minijinja templates
//! (`templates/generator/`, rendered in the crate's one environment, see
//! `emit/templates.rs`); expression code is written by the small `Body`
//! writer below.
//!
//! The `fast` variant is straight-line code: folding, sorting networks and
//! plane tests drive `select`; fetch positions walk axis-aligned steps. The
//! `naive` variant computes the same mathematics with `if`, loops and lookup
//! tables, so the benefit can be measured (and the branch-free check can fail).

pub mod bounds;
pub mod bricks;
pub mod coset;
pub mod cse;
pub mod factored;
pub mod fetch_order;
pub mod forms;
pub mod horner;
pub mod linear;
pub mod locate;
pub mod naive;
mod options;
pub mod plan;
pub mod ridge;
mod templates;
pub mod writer;

use bounds::cube_bounds_fn;
use coset::helpers;
pub use coset::{coset_of, coset_pivots};
use locate::{emit_eval_body, Fast, PieceForm};
use naive::{naive_tables, Naive};
pub use writer::{count_ops, lit};
use writer::{Shapes, AXES};

pub use options::{Bounds, EmitOptions, FetchMode, Layout, SampleMap, Texels, Variant};

use crate::derive::factor::Factorisation;
use crate::derive::Derivation;
use crate::emit::plan::{Locate, Plan};
use crate::error::{Error, Result};
use crate::math::linalg::IVec;
pub use crate::spec::EvalForm;
use serde::Serialize;
use std::fmt::Write;

/// Static cost of one evaluation form, as the cost model sees it.
#[derive(Clone, Debug, Serialize, PartialEq, Eq)]
pub struct FormCost {
    /// The form this is the cost of.
    pub form: EvalForm,
    /// Exact samples fetched per evaluation.
    pub fetches: usize,
    /// Static op count of `<f>_eval`.
    pub ops_eval: usize,
    /// Static op count of `<f>_eval_grad`.
    pub ops_eval_grad: usize,
}

impl FormCost {
    /// The cost model: every operator, comparison, select and builtin call
    /// in eval plus eval_grad counts 1. Exact loads are the same for every
    /// form (the stencil), so they do not enter the choice.
    pub fn cost(&self) -> usize {
        self.ops_eval + self.ops_eval_grad
    }
}

/// Counts reported per emitted module.
#[derive(Clone, Debug, Serialize)]
pub struct EmitStats {
    /// Storage layout of the module.
    pub layout: Layout,
    /// Code shape of the module.
    pub variant: Variant,
    /// The plan's [`Locate`], in `Debug` form.
    pub locate: String,
    /// Number of candidate cells tested after locating the frame.
    pub candidates: usize,
    /// Fetches per evaluation (hardware-filtered ones when `fetch` is linear).
    pub fetches_per_eval: usize,
    /// Vector adds to walk the fetch positions.
    pub vector_adds: usize,
    /// Adds a plain matrix-vector product per fetch would cost instead
    /// (equal to `vector_adds` for the factored form).
    pub matvec_adds: usize,
    /// Arithmetic operators, comparisons, selects and builtin calls in the
    /// source of `eval` / `eval_grad` (a static count, not a timing).
    pub ops_eval: usize,
    /// The same count for `eval_grad`.
    pub ops_eval_grad: usize,
    /// The same count for `eval_hessian` (None below degree 2, where the module has none).
    pub ops_eval_hessian: Option<usize>,
    /// The form of `eval_hessian`: the cheapest by its op count among the
    /// forms with second-order code (or the requested one; ridge is written as power).
    pub hessian_form: Option<EvalForm>,
    /// The form used, and the static cost of every form available here.
    pub form: EvalForm,
    /// Static cost of every form available here (see [`FormCost`]).
    pub forms: Vec<FormCost>,
    /// What fetches do outside the volume.
    pub bounds: Bounds,
    /// Exact loads or hardware-filtered fetches in `eval`.
    pub fetch: FetchMode,
}

/// Re-exported where it was defined first: the table lives beside
/// [`crate::validate::Binding`] so that the back ends, which sit below the
/// emitter, can read it too.
pub use crate::validate::bindings::binding_purpose;

/// One emitted WGSL module: its file name, source and counts.
#[derive(Clone, Debug)]
pub struct Emitted {
    /// File name: `<filter>.<layout>[.naive][.linear][.u8x4].wgsl`.
    pub file_name: String,
    /// The WGSL source.
    pub source: String,
    /// Counts of the module.
    pub stats: EmitStats,
}

/// `<filter>.<layout>.wgsl` or `<filter>.<layout>.naive.wgsl`.
pub fn file_name(filter: &str, layout: Layout, variant: Variant) -> String {
    match variant {
        Variant::Fast => format!("{filter}.{}.wgsl", layout.name()),
        Variant::Naive => format!("{filter}.{}.naive.wgsl", layout.name()),
    }
}

/// Emits the module for one filter.
///
/// # Errors
///
/// [`Error::EmitCap`] when the derivation has more polynomials than
/// `caps.max_emitted_polynomials`; [`Error::Unsupported`] for a 4D module
/// in a bricked layout or with linear fetches (4D samples are a storage
/// buffer), and for linear fetches
/// where they do not apply (the naive variant; the embedded layout outside the
/// one-coset tensor-product case); [`Error::Spec`] when other options cannot be
/// met (`form = "factored"` on a filter that does not factor, the packed layout
/// on a lattice without 2Z^s); [`Error::Template`] if a template fails to
/// render (a generator bug).
pub fn emit(d: &Derivation, opts: &EmitOptions) -> Result<Emitted> {
    if d.facts.dim == 4 {
        // WGSL has no 4D textures: 4D samples live in a storage buffer,
        // which neither a page table over texture bricks nor a sampler reads.
        let refuse = |what: &str, fix: &str| Error::Unsupported {
            origin: format!("filter {}", d.filter.name),
            message: format!("{what} is not offered for 4D filters (their samples are a storage buffer); {fix}"),
        };
        if opts.layout.is_bricked() {
            return Err(refuse(
                &format!("the {} layout", opts.layout.name()),
                "use the embedded or packed layout (layout = embedded or packed)",
            ));
        }
        if opts.fetch == FetchMode::Linear {
            return Err(refuse("hardware-filtered (linear) fetch", "use exact fetches (fetch = exact)"));
        }
        if opts.texels != Texels::Float {
            return Err(refuse("u8x4 texels", "emit with Texels::Float and store the samples as f32"));
        }
    }
    if opts.texels == Texels::U8x4 && opts.fetch == FetchMode::Linear {
        return Err(Error::Unsupported {
            origin: format!("filter {}", d.filter.name),
            message: "hardware-filtered (linear) fetches need a filterable texture, and u8x4 words are integers; use exact fetches or Texels::Float".into(),
        });
    }
    let polynomials = d.polynomials();
    if polynomials > d.filter.caps.max_emitted_polynomials {
        return Err(Error::EmitCap {
            polynomials,
            pieces: d.references.len(),
            cap: d.filter.caps.max_emitted_polynomials,
        });
    }
    let map = opts.samples;
    if !(map.scale.is_finite() && map.scale > 0.0 && map.offset.is_finite()) {
        return Err(Error::Spec {
            origin: format!("filter {}", d.filter.name),
            message: format!(
                "sample map scale {} offset {}: the scale must be finite and > 0 and the offset finite",
                map.scale, map.offset
            ),
        });
    }
    let plan = Plan::new(d);
    let s = d.facts.dim;
    let sh = Shapes::new(s);
    let name = &d.filter.name;
    let naive = opts.variant == Variant::Naive;
    let fac = d.factorisation();
    let mut requested = opts.form.unwrap_or(d.filter.form);
    if opts.fetch == FetchMode::Linear
        && opts.layout == Layout::Embedded
        && requested == EvalForm::Auto
        && fac.is_some()
    {
        // Embedded linear fetches are a property of the factored form.
        requested = EvalForm::Factored;
    }
    let (form, forms, eval_body, grad_body) = if naive {
        // The naive variant measures branches and tables, on the dense form.
        let e = emit_eval_body(d, &plan, &sh, name, 0, &Naive, PieceForm::Dense);
        let g = emit_eval_body(d, &plan, &sh, name, 1, &Naive, PieceForm::Dense);
        let cost = FormCost {
            form: EvalForm::Dense,
            fetches: plan.fetches(),
            ops_eval: count_ops(&e),
            ops_eval_grad: count_ops(&g),
        };
        (EvalForm::Dense, vec![cost], e, g)
    } else {
        choose_form(d, fac.as_ref(), &plan, &sh, name, requested)?
    };
    // Second order: filters of degree >= 2 (a linear piece's Hessian is zero).
    let hessian = if d.facts.degree < 2 {
        None
    } else if naive {
        let h = emit_eval_body(d, &plan, &sh, name, 2, &Naive, PieceForm::Dense);
        Some(HessianCost { form: EvalForm::Dense, ops: count_ops(&h), body: h })
    } else {
        Some(choose_hessian_form(d, fac.as_ref(), &plan, &sh, name, requested, form))
    };
    let (eval_body, fetches_linear) = if opts.fetch == FetchMode::Linear {
        let refuse = |why: &str| Error::Unsupported {
            origin: format!("filter {name}"),
            message: format!("fetch = linear {why}"),
        };
        if naive {
            return Err(refuse("needs the fast variant; use variant = fast or exact fetches"));
        }
        match opts.layout {
            // Every filter: pairs of one coset's samples, one slab per coset.
            Layout::Packed => {
                coset_pivots(&d.filter.lattice)?;
                let lin = linear::LinearPlan::new(d);
                (linear::emit_linear_body(d, &plan, &lin, &sh, name), Some(lin.fetches(&plan)))
            }
            Layout::Bricked | Layout::BrickedPacked => {
                return Err(refuse(
                    "is not offered on the bricked layout (a pair may straddle a slot's halo); use exact fetches",
                ))
            }
            Layout::Embedded => match d.factorisation() {
                Some(fac) if fac.supports_linear_fetch() && form == EvalForm::Factored => {
                    (factored::emit_factored_linear_body(&fac, &sh, name), Some(fac.linear_fetches()))
                }
                Some(_) if form != EvalForm::Factored => {
                    return Err(refuse("on the embedded layout needs the factored form"))
                }
                _ => {
                    return Err(refuse(
                        "on the embedded layout needs a tensor-product filter on one coset with unit steps \
                         (adjacent samples in one texture); use the packed layout (layout = packed), \
                         which pairs the samples of each coset in a filterable texture, or exact fetches",
                    ))
                }
            },
        }
    } else {
        (eval_body, None)
    };
    // Bricked: one page lookup per evaluation, every fetch from that slot.
    let (eval_body, grad_body) = if opts.layout.is_bricked() {
        let paged = |body: &str| {
            format!(
                "    let brick_page = {name}_page(p);\n{}",
                body.replace(&format!("{name}_fetch("), &format!("{name}_fetch_in(brick_page, "))
            )
        };
        (paged(&eval_body), paged(&grad_body))
    } else {
        (eval_body, grad_body)
    };
    let hessian_body = hessian.as_ref().map(|h| {
        if opts.layout.is_bricked() {
            format!(
                "    let brick_page = {name}_page(p);\n{}",
                h.body.replace(&format!("{name}_fetch("), &format!("{name}_fetch_in(brick_page, "))
            )
        } else {
            h.body.clone()
        }
    });
    // The factored form adds one constant offset per fetch after each coset's base.
    let vector_adds = match (&fac, form) {
        (Some(f), EvalForm::Factored) if opts.layout == Layout::Embedded || fetches_linear.is_none() => {
            fetches_linear.map_or(f.fetches() - f.cosets.len(), |_| 0)
        }
        _ => plan.vector_adds,
    };
    let fetches = match form {
        EvalForm::Factored => forms.iter().find(|f| f.form == form).map(|f| f.fetches).unwrap_or(0),
        _ => plan.fetches(),
    };
    let mut helper_text = helpers(&sh, &plan, name);
    if naive {
        helper_text.push_str(&naive_tables(d, &plan, &sh, name));
        helper_text.push('\n');
    }
    // 4D: no min/max kernel. The cube bounds of 4D pieces run to megabytes
    // of WGSL (bcc7 x cubic in t: 3.4 MB); the samples' own min/max over a
    // block (grown by the support) bounds the spline as well, since its
    // weights are non-negative and sum to 1.
    let has_minmax = s <= 3;
    if opts.kernels && has_minmax {
        // Tensor-product filters bound each cube through the factorisation
        // (a contraction, not dense weights of every sample).
        match &fac {
            Some(fac) if !naive && fac.knots_on_cube_faces() => {
                helper_text.push_str(&factored::emit_factored_bounds(fac, &sh, name))
            }
            _ => helper_text.push_str(&cube_bounds_fn(d, &sh, name)),
        }
    }
    let swz: String = AXES[..s].concat();
    // Packed: the coset formula (for the header) and the mask of the pivot
    // axes, whose parity bits pick the coset's tile of the texture.
    let (cosets, coset_formula, coset_mask) =
        match opts.layout {
            Layout::Packed | Layout::BrickedPacked => {
                let piv = coset_pivots(&d.filter.lattice)?;
                let expr: Vec<String> =
                    piv.iter()
                        .enumerate()
                        .map(|(i, &p)| {
                            if i == 0 {
                                format!("(j.{} & 1)", AXES[p])
                            } else {
                                format!("((j.{} & 1) << {i}u)", AXES[p])
                            }
                        })
                        .collect();
                let formula = if expr.is_empty() { "0".to_string() } else { expr.join(" + ") };
                let mask: IVec = (0..s).map(|a| i64::from(piv.contains(&a))).collect();
                (1usize << piv.len(), formula, sh.ivec(&mask))
            }
            Layout::Embedded | Layout::Bricked => (0, String::new(), String::new()),
        };
    let extent_product = match s {
        4 => "e.x * e.y * e.z * e.w",
        3 => "e.x * e.y * e.z",
        _ => "e.x * e.y",
    };
    let delinearize = match s {
        4 => "vec4<i32>(i % e.x, (i / e.x) % e.y, (i / (e.x * e.y)) % e.z, i / (e.x * e.y * e.z))",
        3 => "vec3<i32>(i % e.x, (i / e.x) % e.y, i / (e.x * e.y))",
        _ => "vec2<i32>(i % e.x, i / e.x)",
    };
    let (block_volume, cube_in_block) = if s == 3 {
        ("b * b * b", "vec3<i32>(t % b, (t / b) % b, t / (b * b))")
    } else {
        ("b * b", "vec2<i32>(t % b, t / b)")
    };
    let mut prefilter_body = String::new();
    for (k, w) in &d.prefilter.taps {
        let neg: IVec = k.iter().map(|x| -x).collect();
        let _ = writeln!(prefilter_body, "    acc += {} * {name}_fetch(j + {});", lit(w), sh.ivec(&neg));
    }
    // 4D samples are one storage buffer whatever the layout.
    let storage = s == 4;
    let out_binding = opts.binding + if storage { 1 } else { opts.layout.sample_bindings() };
    let tmpl = templates::env().get_template("module.wgsl.j2").expect("templates::env adds module.wgsl.j2");
    let ctx = minijinja::context! {
        command => opts.command.clone(),
        name => name,
        lattice => d.filter.lattice.name.clone(),
        dim => s,
        layout => opts.layout.name(),
        variant => opts.variant.name(),
        locate => if form == EvalForm::Factored { "tensor product: per coset floor and fraction, no cell location" } else { match plan.locate { Locate::Fold { sort: true } => "fold + sorting network + plane tests", Locate::Fold { sort: false } => "fold + plane tests", Locate::Generic => "generic select over cube classes and cells" } },
        fetches => fetches_linear.unwrap_or(fetches),
        form => form.name(),
        form_costs => forms.iter().map(|f| format!("{} {}/{}", f.form.name(), f.ops_eval, f.ops_eval_grad)).collect::<Vec<_>>().join(", "),
        bounds => opts.bounds.name(),
        vector_adds => vector_adds,
        matvec_adds => if form == EvalForm::Factored { vector_adds } else { plan.matvec_adds },
        group => opts.group,
        binding => opts.binding,
        out_binding => out_binding,
        vecf => sh.vecf,
        veci => sh.veci,
        vecu => format!("vec{s}<u32>"),
        gradf => if storage { format!("{name}_Gradient") } else { format!("vec{}<f32>", s + 1) },
        swz => swz,
        coset_formula => coset_formula,
        coset_mask => coset_mask,
        cosets => cosets,
        helpers => helper_text,
        eval_body => eval_body.clone(),
        grad_body => grad_body.clone(),
        hessian_body => hessian_body.clone().unwrap_or_default(),
        has_hessian => hessian_body.is_some(),
        hessian_form => hessian.as_ref().map(|h| h.form.name()).unwrap_or(""),
        matf => format!("mat{s}x{s}<f32>"),
        has_kernels => opts.kernels,
        has_minmax => has_minmax,
        storage => storage,
        extent_product => extent_product,
        delinearize => delinearize,
        block_volume => block_volume,
        cube_in_block => cube_in_block,
        prefilter_body => prefilter_body,
        clamp => opts.bounds == Bounds::Clamp,
        linear => opts.fetch == FetchMode::Linear,
        words => opts.texels == Texels::U8x4,
        texel_type => if opts.texels == Texels::U8x4 { "u32" } else { "f32" },
        word_shift => if s == 3 { "vec3<u32>(2u, 0u, 0u)" } else { "vec2<u32>(2u, 0u)" },
        word_width => if s == 3 { "vec3<i32>(4, 1, 1)" } else { "vec2<i32>(4, 1)" },
        mapped => !map.is_identity(),
        sample_scale => lit_f32(map.scale),
        sample_offset => lit_f32(map.offset),
        halo => match opts.layout {
            Layout::Bricked => bricks::brick_halo(d),
            Layout::BrickedPacked => bricks::brick_halo(d).next_multiple_of(2),
            _ => 0,
        },
    };
    let source = tmpl.render(ctx).map_err(|source| Error::Template { filter: name.to_string(), source })?;
    let stats = EmitStats {
        layout: opts.layout,
        variant: opts.variant,
        locate: format!("{:?}", plan.locate),
        candidates: plan.candidates.len(),
        fetches_per_eval: fetches_linear.unwrap_or(fetches),
        vector_adds,
        matvec_adds: if form == EvalForm::Factored { vector_adds } else { plan.matvec_adds },
        ops_eval: count_ops(&eval_body),
        ops_eval_grad: count_ops(&grad_body),
        ops_eval_hessian: hessian_body.as_deref().map(count_ops),
        hessian_form: hessian.as_ref().map(|h| h.form),
        form,
        forms,
        bounds: opts.bounds,
        fetch: opts.fetch,
    };
    let mut file = file_name(name, opts.layout, opts.variant);
    if opts.fetch == FetchMode::Linear {
        file = file.replace(".wgsl", ".linear.wgsl");
    }
    if opts.texels == Texels::U8x4 {
        file = file.replace(".wgsl", ".u8x4.wgsl");
    }
    Ok(Emitted { file_name: file, source, stats })
}

/// An f32 as a WGSL literal that reads back as the same f32.
fn lit_f32(x: f32) -> String {
    let t = format!("{x:?}");
    if t.contains('.') || t.contains('e') {
        t
    } else {
        format!("{t}.0")
    }
}

/// The ridge form's highest degree. Above it the products of high powers of
/// shifted knot-plane forms lose too much to cancellation in f32: the device
/// check measured 2.2e-5 (cc_triquadratic, degree 6) and 2.4e-4 to 3.1e-4
/// (bcc12, cc_tricubic, degree 9) of the data range against the exact
/// evaluator, over the 1e-5 that every other form meets; the catalog's
/// filters of degree 1 to 5 (bcc_linear, fcc6, bcc7, bcc8, ...) pass it.
pub const RIDGE_MAX_DEGREE: usize = 5;

/// Emits every available form, and picks the requested one or (auto) the
/// cheapest by [`FormCost::cost`]; ties go to the earlier of factored,
/// power, ridge, bb, dense. Returns (form, every form's cost, eval body, grad body).
fn choose_form(
    d: &Derivation,
    fac: Option<&Factorisation>,
    plan: &Plan,
    sh: &Shapes,
    name: &str,
    requested: EvalForm,
) -> Result<(EvalForm, Vec<FormCost>, String, String)> {
    if requested == EvalForm::Factored && fac.is_none() {
        return Err(Error::Spec {
            origin: format!("filter {name}"),
            message:
                "form = \"factored\" needs every direction along a coordinate axis, one length per axis, \
                      and that length's axis vector in the lattice; use form = \"auto\", \"power\", \"ridge\" or \"bb\""
                    .into(),
        });
    }
    let ridge_ok = d.facts.degree <= RIDGE_MAX_DEGREE;
    if requested == EvalForm::Ridge && !ridge_ok {
        return Err(Error::Unsupported {
            origin: format!("filter {name}"),
            message: format!(
                "form = \"ridge\" is offered up to degree {RIDGE_MAX_DEGREE} (this filter has degree {}): its high powers of \
                 shifted linear forms cancel in f32; use form = \"auto\", \"power\" or \"bb\"",
                d.facts.degree
            ),
        });
    }
    let mut bodies: Vec<(EvalForm, usize, String, String)> = Vec::new();
    let wanted = |f: EvalForm| requested == EvalForm::Auto || requested == f;
    if let Some(fac) = fac {
        if wanted(EvalForm::Factored) {
            let e = factored::emit_factored_body(fac, sh, name, 0);
            let g = factored::emit_factored_body(fac, sh, name, 1);
            bodies.push((EvalForm::Factored, fac.fetches(), e, g));
        }
    }
    // The tensor forms of large filters are far cheaper than the plan-based
    // ones; skip deriving those (CSE over 128 x 220 weights) unless asked.
    let skip_plan_forms = requested == EvalForm::Auto && fac.is_some() && plan.fetches() > 64;
    for (f, piece) in [
        (EvalForm::Power, PieceForm::Power),
        (EvalForm::Ridge, PieceForm::Ridge),
        (EvalForm::Bb, PieceForm::Bb),
        (EvalForm::Dense, PieceForm::Dense),
    ] {
        if wanted(f) && !skip_plan_forms && (f != EvalForm::Ridge || ridge_ok) {
            let e = emit_eval_body(d, plan, sh, name, 0, &Fast, piece);
            let g = emit_eval_body(d, plan, sh, name, 1, &Fast, piece);
            bodies.push((f, plan.fetches(), e, g));
        }
    }
    let forms: Vec<FormCost> = bodies
        .iter()
        .map(|(f, n, e, g)| FormCost { form: *f, fetches: *n, ops_eval: count_ops(e), ops_eval_grad: count_ops(g) })
        .collect();
    let best = (0..forms.len()).min_by_key(|&i| (forms[i].cost(), i)).expect(
        "factored is emitted when asked for (checked above) or when plan forms are skipped, else plan forms are",
    );
    let (f, _, e, g) = bodies.swap_remove(best);
    Ok((f, forms, e, g))
}

/// One emitted `eval_hessian` body with its form and static op count.
struct HessianCost {
    form: EvalForm,
    ops: usize,
    body: String,
}

/// The `eval_hessian` body: the requested form's second-order code (ridge,
/// which has none, as power), or (auto) the cheapest of factored, power, bb
/// bb by static op count (dense is bb without shared subexpressions); ties
/// go to the eval form, then that order.
fn choose_hessian_form(
    d: &Derivation,
    fac: Option<&Factorisation>,
    plan: &Plan,
    sh: &Shapes,
    name: &str,
    requested: EvalForm,
    eval_form: EvalForm,
) -> HessianCost {
    let plan_body = |piece: PieceForm| emit_eval_body(d, plan, sh, name, 2, &Fast, piece);
    let one = |form: EvalForm, body: String| HessianCost { form, ops: count_ops(&body), body };
    match (requested, fac) {
        (EvalForm::Factored, Some(fac)) => {
            return one(EvalForm::Factored, factored::emit_factored_body(fac, sh, name, 2))
        }
        (EvalForm::Power | EvalForm::Ridge, _) => return one(EvalForm::Power, plan_body(PieceForm::Power)),
        (EvalForm::Bb, _) => return one(EvalForm::Bb, plan_body(PieceForm::Bb)),
        (EvalForm::Dense, _) => return one(EvalForm::Dense, plan_body(PieceForm::Dense)),
        _ => {}
    }
    let mut all: Vec<HessianCost> = Vec::new();
    if let Some(fac) = fac {
        all.push(one(EvalForm::Factored, factored::emit_factored_body(fac, sh, name, 2)));
    }
    // As for eval: large tensor products skip the plan-based forms.
    if !(fac.is_some() && plan.fetches() > 64) {
        for (f, piece) in [(EvalForm::Power, PieceForm::Power), (EvalForm::Bb, PieceForm::Bb)] {
            all.push(one(f, plan_body(piece)));
        }
    }
    let best = (0..all.len())
        .min_by_key(|&i| (all[i].ops, all[i].form != eval_form, i))
        .expect("factored is available when the plan forms are skipped");
    all.swap_remove(best)
}
