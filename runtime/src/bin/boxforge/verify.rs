//! `boxforge verify`: a filter's eval / eval_grad on the GPU against the
//! exact evaluator; exit 1 when it fails.

use crate::common::{Failure, FetchArg, FormArg, LayoutArg, TargetArg, VariantArg};
use crate::request;
use boxforge::derive::Derivation;
use boxforge::emit::{Bounds, EvalForm, FetchMode, Layout, Variant};
use boxforge::spec;
use boxforge_runtime::gpu::Gpu;

#[derive(clap::Args)]
pub struct VerifyArgs {
    /// Catalog name or spec file (3D filters).
    #[arg(long)]
    filter: String,
    #[arg(long, value_enum, default_value = "embedded")]
    layout: LayoutArg,
    #[arg(long, value_enum, default_value = "fast")]
    variant: VariantArg,
    /// Evaluation form (default: the filter's own, `auto`: the cheapest).
    #[arg(long, value_enum)]
    form: Option<FormArg>,
    /// Fetch bounds: clamp to the volume, or unchecked (caller pads).
    #[arg(long, value_enum, default_value = "clamp")]
    bounds: BoundsArg,
    /// Fetches in eval: exact texel loads, or hardware linear filtering
    /// (tensor-product filters on the cc lattice, embedded layout).
    #[arg(long, value_enum, default_value = "exact")]
    fetch: FetchArg,
    #[arg(long, default_value_t = 100_000)]
    points: usize,
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Adapter name (substring); default: WGPU_ADAPTER_NAME or the best available.
    #[arg(long)]
    adapter: Option<String>,
    #[arg(long)]
    json: bool,
    /// Shading language to run: the WGSL module (default), or its
    /// translation run as emitted: spirv (the eval kernel binary), glsl and
    /// hlsl (the library with boxforge's entry point, compiled by glslang)
    /// on Vulkan by passthrough, or glsl as text on an OpenGL driver.
    #[arg(long, value_enum, default_value = "wgsl")]
    target: TargetArg,
    /// Where it runs: the Vulkan device, or OpenGL (WGSL through wgpu's GL
    /// backend; GLSL through the driver's own compiler, EGL without a window).
    #[arg(long, value_enum, default_value = "vulkan")]
    backend: BackendArg,
}

/// `--backend`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum BackendArg {
    Vulkan,
    Gl,
}

/// `--bounds`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum BoundsArg {
    Clamp,
    Unchecked,
}

impl From<BoundsArg> for Bounds {
    fn from(b: BoundsArg) -> Bounds {
        match b {
            BoundsArg::Clamp => Bounds::Clamp,
            BoundsArg::Unchecked => Bounds::Unchecked,
        }
    }
}

pub fn run(a: VerifyArgs) -> Result<(), Failure> {
    let VerifyArgs { filter, layout, variant, form, bounds, fetch, points, seed, adapter, json, target, backend } = a;
    request::check_points(points)?;
    let f = spec::resolve(&filter)?;
    let d = Derivation::new(&f)?;
    if target != TargetArg::Wgsl {
        return run_target(
            &d,
            layout,
            variant,
            target,
            backend,
            points,
            seed,
            adapter.as_deref(),
            json,
            (form, bounds, fetch),
        );
    }
    let backends = (backend == BackendArg::Gl).then_some(wgpu::Backends::GL);
    let gpu = Gpu::with_backends(adapter.as_deref(), backends).map_err(|e| Failure(e.to_string()))?;
    let layout = Layout::from(layout);
    let variant = Variant::from(variant);
    let form = form.map(EvalForm::from);
    let r = boxforge_runtime::verify::verify_fetch(
        &gpu,
        &d,
        layout,
        variant,
        form,
        Bounds::from(bounds),
        FetchMode::from(fetch),
        points,
        seed,
    )
    .map_err(|e| Failure(e.to_string()))?;
    if json {
        outln!("{}", serde_json::to_string(&r).unwrap());
    } else {
        outln!(
            "{} ({}, {}, form {}, {} {} fetches) on {}: {}",
            r.filter,
            layout.name(),
            variant.name(),
            r.form.name(),
            r.bounds.name(),
            r.fetch.name(),
            r.adapter,
            results(&r)
        );
    }
    if r.passed {
        Ok(())
    } else {
        std::process::exit(1)
    }
}

/// The measured part of a report's line, and its verdict.
fn results(r: &boxforge_runtime::verify::VerifyReport) -> String {
    let hessian = match (r.hessian_form, r.max_rel_hessian_err) {
        (Some(form), Some(err)) => format!(
            ", eval_hessian (form {}) max relative Hessian error {err:.3e} ({} matched the piece across a knot plane)",
            form.name(),
            r.hessian_accepted_other_side
        ),
        _ => String::new(),
    };
    format!(
        "{} points, max |value error| {:.3e} (range {:.3}), max relative gradient error {:.3e}, {} near a knot plane ({} matched the piece across it){hessian}: {}",
        r.points,
        r.max_abs_err,
        r.data_range,
        r.max_rel_grad_err,
        r.near_knot_points,
        r.accepted_other_side,
        if r.passed { "PASSED" } else { "FAILED" }
    )
}

/// `verify --target X`: a translation, run as emitted.
#[allow(clippy::too_many_arguments)]
fn run_target(
    d: &Derivation,
    layout: LayoutArg,
    variant: VariantArg,
    target: TargetArg,
    backend: BackendArg,
    points: usize,
    seed: u64,
    adapter: Option<&str>,
    json: bool,
    (form, bounds, fetch): (Option<FormArg>, BoundsArg, FetchArg),
) -> Result<(), Failure> {
    use boxforge_runtime::targets::Runner;
    if form.is_some() || bounds != BoundsArg::Clamp {
        return Err(Failure(
            "--target runs the filter's own form with clamped fetches: leave out --form and --bounds".into(),
        ));
    }
    let target = boxforge::back::Target::from(target);
    let runner = match backend {
        BackendArg::Vulkan => Runner::Vulkan,
        BackendArg::Gl => Runner::Gl,
    };
    let gpu = match runner {
        Runner::Vulkan => Some(Gpu::new(adapter).map_err(|e| Failure(e.to_string()))?),
        Runner::Gl => None,
    };
    let layout = Layout::from(layout);
    let variant = Variant::from(variant);
    let t = boxforge_runtime::verify::target::verify_target(
        gpu.as_ref(),
        d,
        layout,
        variant,
        fetch.into(),
        target,
        runner,
        points,
        seed,
    )
    .map_err(|e| Failure(e.to_string()))?;
    let r = &t.report;
    if json {
        outln!("{}", serde_json::to_string(&t).unwrap());
    } else {
        outln!(
            "{} ({}, {}, form {}, {} fetches) in {} run by {}: {}",
            r.filter,
            layout.name(),
            variant.name(),
            r.form.name(),
            r.fetch.name(),
            target.language(),
            r.adapter,
            results(r)
        );
    }
    if r.passed {
        Ok(())
    } else {
        std::process::exit(1)
    }
}
