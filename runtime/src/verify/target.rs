//! `verify --target`: a translation into another shading language, run as
//! emitted ([`crate::targets`]), against the exact evaluator with the same
//! points, tolerances and near-knot rule as the WGSL module.

use super::inputs::{data_range, random_volume};
use super::{check_request, device_volume, tally_points, VerifyError, VerifyReport};
use crate::gpu::Gpu;
use crate::targets::{Runner, TargetEvaluator};
use boxforge::back::{translate, Target, TranslateOptions};
use boxforge::derive::Derivation;
use boxforge::emit::{emit, Bounds, EmitOptions, FetchMode, Layout, Variant};

/// A [`VerifyReport`] of a translation: which language, where it ran, and
/// what compiled it (in `report.adapter`).
#[derive(Clone, Debug)]
#[cfg_attr(feature = "files", derive(serde::Serialize))]
pub struct TargetVerifyReport {
    pub target: Target,
    pub runner: Runner,
    #[cfg_attr(feature = "files", serde(flatten))]
    pub report: VerifyReport,
}

/// Emits `d` in `layout`/`variant` with clamped `fetch`es, translates it
/// into `target`, runs it with `runner` (the wgpu device `gpu` for
/// [`Runner::Vulkan`]; an OpenGL context of its own for [`Runner::Gl`]) at
/// `points` random points of a random volume, and checks every value and
/// gradient against the exact evaluator.
#[allow(clippy::too_many_arguments)]
pub fn verify_target(
    gpu: Option<&Gpu>,
    d: &Derivation,
    layout: Layout,
    variant: Variant,
    fetch: FetchMode,
    target: Target,
    runner: Runner,
    points: usize,
    seed: u64,
) -> Result<TargetVerifyReport, VerifyError> {
    check_request(d, points)?;
    let options = EmitOptions {
        layout,
        variant,
        kernels: false,
        fetch,
        command: format!("boxforge verify --target {target}"),
        ..Default::default()
    };
    let module = emit(d, &options)?;
    let stem = module.file_name.trim_end_matches(".wgsl").to_string();
    let translated = translate(&module.source, &stem, target, &TranslateOptions::default())
        .map_err(crate::targets::TargetError::from)?;
    let vol = random_volume(d, seed);
    let (evaluator, dv) = match (runner, gpu) {
        (Runner::Vulkan, Some(gpu)) => {
            let dv = device_volume(gpu, d, &vol, layout, fetch)?;
            (TargetEvaluator::vulkan(gpu, &translated, &dv)?, Some(dv))
        }
        (Runner::Vulkan, None) => return Err(VerifyError::NoDevice),
        #[cfg(feature = "gl-run")]
        (Runner::Gl, _) => (TargetEvaluator::gl(&translated, &vol, layout)?, None),
        #[cfg(not(feature = "gl-run"))]
        (Runner::Gl, _) => {
            return Err(crate::targets::TargetError::Unsupported {
                target,
                runner: "gl",
                why: "this build leaves out the GL runner (cargo feature gl-run)".into(),
            }
            .into())
        }
    };
    let range = data_range(&vol);
    let tally = tally_points(d, &vol, points, seed, |pts| evaluator.eval(gpu, dv.as_ref(), pts))?;
    let passed = tally.passed();
    Ok(TargetVerifyReport {
        target,
        runner,
        report: VerifyReport {
            filter: d.filter.name.clone(),
            layout,
            variant,
            form: module.stats.form,
            bounds: Bounds::Clamp,
            fetch,
            points,
            max_abs_err: tally.max_abs,
            max_rel_grad_err: tally.max_rel,
            data_range: range,
            near_knot_points: tally.near_knot_points,
            accepted_other_side: tally.accepted_other_side,
            // Translations are checked on eval and eval_grad; the WGSL
            // module's eval_hessian is checked by `verify` on the device.
            hessian_form: None,
            max_rel_hessian_err: None,
            hessian_accepted_other_side: 0,
            passed,
            adapter: evaluator.how.clone(),
        },
    })
}
