//! Device verification on lavapipe (or any Vulkan device): every 3D catalog
//! filter, every layout, fast variant; eval, eval_grad and (degree >= 2)
//! eval_hessian against the exact evaluator. Sizes are small enough for CI.

use boxforge::derive::Derivation;
use boxforge::emit::{Layout, Variant};
use boxforge_runtime::gpu::Gpu;
use boxforge_runtime::verify::verify;

fn gpu() -> &'static Gpu {
    crate::common::gpu()
}

#[test]
fn every_3d_catalog_filter_matches_the_exact_evaluator_on_the_device() {
    let gpu = gpu();
    let mut failures = Vec::new();
    for name in boxforge::spec::catalog::names() {
        let d = Derivation::new(&boxforge::spec::catalog::get(name).unwrap()).unwrap();
        if d.facts.dim != 3 {
            continue;
        }
        // The bricked layouts in bricks of 4 (`verify::VERIFY_BRICK_EDGE`),
        // with as many points again on the brick faces.
        for layout in [Layout::Embedded, Layout::Packed, Layout::Bricked, Layout::BrickedPacked] {
            let r = verify(gpu, &d, layout, Variant::Fast, 3000, 7).unwrap();
            eprintln!(
                "{name} {layout:?}: value {:.2e} grad {:.2e} hessian {:?}",
                r.max_abs_err, r.max_rel_grad_err, r.max_rel_hessian_err
            );
            // Second order is checked wherever the module has it.
            assert_eq!(r.max_rel_hessian_err.is_some(), d.facts.degree >= 2, "{name} {layout:?}");
            if !r.passed {
                failures.push(format!("{name} {layout:?}: {r:?}"));
            }
        }
    }
    assert!(failures.is_empty(), "{failures:#?}");
}

#[test]
fn the_naive_variant_computes_the_same_spline() {
    let gpu = gpu();
    let d = Derivation::new(&boxforge::spec::catalog::get("bcc_linear").unwrap()).unwrap();
    let r = verify(gpu, &d, Layout::Embedded, Variant::Naive, 2000, 3).unwrap();
    assert!(r.passed, "{r:?}");
}

#[test]
fn verification_can_fail() {
    let gpu = gpu();
    let bcc7 = Derivation::new(&boxforge::spec::catalog::get("bcc7").unwrap()).unwrap();
    let vol = boxforge_runtime::verify::random_volume(&bcc7, 5);
    let pts = boxforge_runtime::verify::random_points(&bcc7, &vol, 200, 5);
    let dv = boxforge_runtime::volume::DeviceVolume::new(gpu, &vol, Layout::Embedded).unwrap();
    let (values, grads) = boxforge_runtime::verify::gpu_eval(gpu, &bcc7, &dv, Variant::Fast, &pts).unwrap();
    let exact = boxforge_runtime::verify::cpu_eval(&bcc7, &vol, &pts);
    let max = values.iter().zip(&exact).map(|(v, e)| (*v as f64 - e.0).abs()).fold(0f64, f64::max);
    assert!(max < 1e-5, "bcc7 itself agrees ({max})");
    // Against slightly different data (1% larger) the same comparison fails.
    let mut vol2 = vol.clone();
    vol2.data.iter_mut().for_each(|v| *v *= 1.01);
    let exact2 = boxforge_runtime::verify::cpu_eval(&bcc7, &vol2, &pts);
    let max2 = values.iter().zip(&exact2).map(|(v, e)| (*v as f64 - e.0).abs()).fold(0f64, f64::max);
    assert!(max2 > 1e-3, "a 1% data change must be visible ({max2})");
    // The verifier's own comparison (near-knot rule included) fails it too.
    let range = boxforge_runtime::verify::data_range(&vol);
    let mut t = boxforge_runtime::verify::Tally::new(range);
    t.check(&bcc7, &vol, &pts, &values, &grads);
    assert!(t.passed(), "bcc7 against its own data: {t:?}");
    let mut t2 = boxforge_runtime::verify::Tally::new(range);
    t2.check(&bcc7, &vol2, &pts, &values, &grads);
    assert!(!t2.passed(), "against 1% larger data: {t2:?}");
}

/// bcc_linear is only C0: on a knot plane its gradient jumps, and the device
/// may place a point within f32 rounding of the plane in either piece.
/// (a) Points put on the derivation's knot planes (a random point projected
/// onto the nearest plane of one family, rounded to f32) all count as
/// near-knot and pass, matching the piece on one side or the other;
/// (b) points far from every plane with a perturbed gradient still fail, and
/// so does an on-plane point whose gradient matches neither side.
#[test]
fn knot_plane_points_pass_either_side_and_wrong_gradients_still_fail() {
    use boxforge_runtime::verify::{data_range, gpu_eval, near_knot, random_points, random_volume, Tally};
    use boxforge_runtime::volume::DeviceVolume;
    let gpu = gpu();
    let d = Derivation::new(&boxforge::spec::catalog::get("bcc_linear").unwrap()).unwrap();
    let vol = random_volume(&d, 3);
    let dv = DeviceVolume::new(gpu, &vol, Layout::Embedded).unwrap();
    let range = data_range(&vol);
    let x64 = |p: &[f32; 4]| [p[0] as f64, p[1] as f64, p[2] as f64];
    let families = &d.arrangement.families;
    assert!(!families.is_empty());
    let seeds = random_points(&d, &vol, 4000, 3);
    let on: Vec<[f32; 4]> = seeds
        .iter()
        .enumerate()
        .map(|(i, p)| {
            let f = &families[i % families.len()];
            let n: Vec<f64> = f.normal.iter().map(|a| *a as f64).collect();
            let (offset, period) = (f.offset.to_f64(), f.period as f64);
            let x = x64(p);
            let v: f64 = n.iter().zip(&x).map(|(a, b)| a * b).sum();
            let c = offset + ((v - offset) / period).round() * period;
            let t = (v - c) / n.iter().map(|a| a * a).sum::<f64>();
            [(x[0] - t * n[0]) as f32, (x[1] - t * n[1]) as f32, (x[2] - t * n[2]) as f32, 0.0]
        })
        .collect();
    assert!(on.iter().all(|p| near_knot(&d, &x64(p)).is_some()), "every projected point is near its plane");
    let (values, grads) = gpu_eval(gpu, &d, &dv, Variant::Fast, &on).unwrap();
    let mut t = Tally::new(range);
    t.check(&d, &vol, &on, &values, &grads);
    eprintln!("bcc_linear on knot planes: {t:?}");
    assert_eq!(t.near_knot_points, on.len());
    assert!(t.passed(), "{t:?}");
    assert!(t.accepted_other_side > 0, "the device put some points in the other piece: {t:?}");
    // An on-plane point whose gradient matches neither side fails.
    let mut bad = grads.clone();
    bad[0][1] += 0.5;
    let mut t = Tally::new(range);
    t.check(&d, &vol, &on[..1], &values[..1], &bad[..1]);
    assert!(!t.passed() && t.near_knot_points == 1, "{t:?}");

    // (b) Far from every plane: exact agreement, and a perturbed gradient fails.
    let far: Vec<[f32; 4]> =
        random_points(&d, &vol, 500, 9).into_iter().filter(|p| near_knot(&d, &x64(p)).is_none()).collect();
    assert!(far.len() > 400);
    let (values, grads) = gpu_eval(gpu, &d, &dv, Variant::Fast, &far).unwrap();
    let mut t = Tally::new(range);
    t.check(&d, &vol, &far, &values, &grads);
    assert!(t.passed() && t.near_knot_points == 0, "{t:?}");
    for i in [0, far.len() / 2, far.len() - 1] {
        let mut bad = grads.clone();
        bad[i][2] += 1e-3 * range.max(bad[i][2].abs() as f64) as f32;
        let mut t = Tally::new(range);
        t.check(&d, &vol, &far, &values, &bad);
        assert!(!t.passed() && t.accepted_other_side == 0, "point {i}: {t:?}");
    }
}

#[test]
fn a_missing_adapter_name_is_a_clear_error() {
    let e = Gpu::new(Some("no-such-adapter-xyz")).err().expect("no adapter of that name");
    let msg = e.to_string();
    assert!(msg.contains("no-such-adapter-xyz") && msg.contains("available"), "{msg}");
}

/// Every evaluation form the generator offers for a filter computes the same
/// spline on the device (the cost model only picks among exact forms), and
/// the unchecked bounds policy agrees where the support is inside the volume.
#[test]
fn every_evaluation_form_matches_the_exact_evaluator_on_the_device() {
    use boxforge::emit::{Bounds, EvalForm};
    use boxforge_runtime::verify::verify_with;
    let gpu = gpu();
    let mut failures = Vec::new();
    let cases: [(&str, &[EvalForm]); 4] = [
        ("bcc7", &[EvalForm::Power, EvalForm::Ridge, EvalForm::Bb, EvalForm::Dense]),
        ("fcc6", &[EvalForm::Power, EvalForm::Ridge, EvalForm::Bb]),
        ("cc_tricubic", &[EvalForm::Factored, EvalForm::Power]),
        ("bcc12", &[EvalForm::Factored]),
    ];
    for (name, forms) in cases {
        let d = Derivation::new(&boxforge::spec::catalog::get(name).unwrap()).unwrap();
        for &form in forms {
            for (layout, bounds) in [(Layout::Embedded, Bounds::Clamp), (Layout::Packed, Bounds::Unchecked)] {
                let r = verify_with(gpu, &d, layout, Variant::Fast, Some(form), bounds, 1500, 11).unwrap();
                assert_eq!(r.form, form, "{name}: the forced form is the one emitted");
                eprintln!(
                    "{name} {form:?} {layout:?} {bounds:?}: value {:.2e} grad {:.2e}",
                    r.max_abs_err, r.max_rel_grad_err
                );
                if !r.passed {
                    failures.push(format!("{name} {form:?} {layout:?} {bounds:?}: {r:?}"));
                }
            }
        }
    }
    assert!(failures.is_empty(), "{failures:#?}");
}

/// Hardware-filtered (linear) fetches: tricubic in 8 fetches and trilinear
/// in one, within 1e-5 of the range on lavapipe (which filters in float).
#[test]
fn linear_fetches_match_the_exact_evaluator_on_the_device() {
    use boxforge::emit::{Bounds, FetchMode};
    use boxforge_runtime::verify::verify_fetch;
    let gpu = gpu();
    if !gpu.device.features().contains(wgpu::Features::FLOAT32_FILTERABLE) {
        eprintln!("skipped: this adapter cannot filter R32Float");
        return;
    }
    for name in ["cc_tricubic", "cc_trilinear", "cc_triquadratic"] {
        let d = Derivation::new(&boxforge::spec::catalog::get(name).unwrap()).unwrap();
        let r =
            verify_fetch(gpu, &d, Layout::Embedded, Variant::Fast, None, Bounds::Clamp, FetchMode::Linear, 1500, 13)
                .unwrap();
        eprintln!("{name} linear: value {:.2e} grad {:.2e}", r.max_abs_err, r.max_rel_grad_err);
        assert!(r.passed, "{name}: {r:?}");
    }
    // Filters without a one-coset tensor structure are refused on the
    // embedded layout with a reason that names the packed layout.
    let bcc7 = Derivation::new(&boxforge::spec::catalog::get("bcc7").unwrap()).unwrap();
    let e = verify_fetch(gpu, &bcc7, Layout::Embedded, Variant::Fast, None, Bounds::Clamp, FetchMode::Linear, 10, 1)
        .unwrap_err()
        .to_string();
    assert!(e.contains("fetch = linear") && e.contains("layout = packed"), "{e}");
    // Packed: pairs of each coset's samples through the coset-slab texture
    // (points a support radius inside; the borders have their own test).
    for name in ["bcc7", "bcc8", "fcc6", "bcc_linear", "cc_tricubic"] {
        let d = Derivation::new(&boxforge::spec::catalog::get(name).unwrap()).unwrap();
        let r = verify_fetch(gpu, &d, Layout::Packed, Variant::Fast, None, Bounds::Clamp, FetchMode::Linear, 1500, 17)
            .unwrap();
        eprintln!("{name} packed linear: value {:.2e} grad {:.2e}", r.max_abs_err, r.max_rel_grad_err);
        assert!(r.passed, "{name}: {r:?}");
    }
}

/// Packed linear fetches clamp like the packed exact loads: at points out to
/// three texels past every face, the filtered eval equals the exact one
/// (both modules on the same volume, on the device).
#[test]
fn packed_linear_fetches_clamp_like_exact_loads() {
    use boxforge::emit::{emit, EmitOptions, FetchMode};
    use boxforge_runtime::verify::{random_volume, PointEvaluator};
    use boxforge_runtime::volume::DeviceVolume;
    let gpu = gpu();
    if !gpu.device.features().contains(wgpu::Features::FLOAT32_FILTERABLE) {
        eprintln!("skipped: this adapter cannot filter R32Float");
        return;
    }
    for name in ["bcc7", "fcc6"] {
        let d = Derivation::new(&boxforge::spec::catalog::get(name).unwrap()).unwrap();
        let vol = random_volume(&d, 5);
        let n = vol.dims[0] as f32;
        let mut seed = 7u64;
        let pts: Vec<[f32; 4]> = (0..4000)
            .map(|_| {
                let mut p = [0f32; 4];
                for pi in p.iter_mut().take(3) {
                    seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
                    *pi = -3.0 + (seed >> 40) as f32 / (1u64 << 24) as f32 * (n + 5.0);
                }
                p
            })
            .collect();
        let run = |fetch: FetchMode| {
            let dv = if fetch == FetchMode::Linear {
                DeviceVolume::new_filtered(gpu, &vol, Layout::Packed).unwrap()
            } else {
                DeviceVolume::new(gpu, &vol, Layout::Packed).unwrap()
            };
            let opts = EmitOptions { layout: Layout::Packed, kernels: false, fetch, ..EmitOptions::default() };
            let m = emit(&d, &opts).unwrap();
            PointEvaluator::new(gpu, &m.source, &m.file_name, name, &dv).unwrap().eval(&pts).unwrap().0
        };
        let (exact, linear) = (run(FetchMode::Exact), run(FetchMode::Linear));
        let worst = exact.iter().zip(&linear).map(|(a, b)| (a - b).abs()).fold(0f32, f32::max);
        eprintln!("{name}: packed linear vs exact near the borders: {worst:.2e}");
        assert!(worst < 1e-5, "{name}: {worst}");
    }
}

/// Issue #8's "nothing lost": every 3D catalog filter x layout x evaluation
/// form x fetch mode that the generator offers computes the same spline on
/// the device (value within 1e-5 of the range, gradient within 1e-4), and
/// the combinations it refuses are refused with a reason, never emitted wrong.
#[test]
fn every_filter_layout_form_and_fetch_mode_matches_the_exact_evaluator() {
    use boxforge::emit::{Bounds, EvalForm, FetchMode};
    use boxforge_runtime::verify::verify_fetch;
    let gpu = gpu();
    let filterable = gpu.device.features().contains(wgpu::Features::FLOAT32_FILTERABLE);
    let (mut checked, mut refused, mut failures) = (0, 0, Vec::new());
    for name in boxforge::spec::catalog::names() {
        let d = Derivation::new(&boxforge::spec::catalog::get(name).unwrap()).unwrap();
        if d.facts.dim != 3 {
            continue;
        }
        let forms: Vec<EvalForm> = EvalForm::ALL
            .into_iter()
            .filter(|f| *f != EvalForm::Auto && (*f != EvalForm::Factored || d.factorisation().is_some()))
            .collect();
        for &form in &forms {
            for layout in [Layout::Embedded, Layout::Packed] {
                for fetch in [FetchMode::Exact, FetchMode::Linear] {
                    if fetch == FetchMode::Linear && !filterable {
                        continue;
                    }
                    let r = verify_fetch(gpu, &d, layout, Variant::Fast, Some(form), Bounds::Clamp, fetch, 300, 29);
                    match r {
                        Ok(r) => {
                            checked += 1;
                            assert_eq!(r.form, form, "{name}: the forced form is the one emitted");
                            if !r.passed {
                                failures.push(format!("{name} {form:?} {layout:?} {fetch:?}: {r:?}"));
                            }
                        }
                        // The ridge form is offered up to a degree (f32 cancellation beyond).
                        Err(e) if form == EvalForm::Ridge && d.facts.degree > boxforge::emit::RIDGE_MAX_DEGREE => {
                            refused += 1;
                            assert!(e.to_string().contains("ridge"), "{name}: {e}");
                        }
                        // Linear fetches on the embedded layout exist only for
                        // one-coset tensor products in the factored form.
                        Err(e) if fetch == FetchMode::Linear && layout == Layout::Embedded => {
                            refused += 1;
                            assert!(e.to_string().contains("fetch = linear"), "{name} {form:?}: {e}");
                        }
                        Err(e) => failures.push(format!("{name} {form:?} {layout:?} {fetch:?}: error {e}")),
                    }
                }
            }
        }
    }
    eprintln!("{checked} combinations verified, {refused} refused with a reason");
    assert!(failures.is_empty(), "{failures:#?}");
    assert!(checked >= 70, "{checked}");
}
