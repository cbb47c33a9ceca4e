//! `<f>_eval_hessian` on the device: a mutated Hessian coefficient fails the
//! check (so it can fail), and on knot planes of a C^1 filter, where the
//! Hessian jumps, the device's Hessian matches the piece on one side or the
//! other (counted), never a looser tolerance.

use boxforge::derive::Derivation;
use boxforge::emit::{emit, EmitOptions, Layout};
use boxforge_runtime::verify::hessian::{HessianEvaluator, HessianTally};
use boxforge_runtime::verify::{data_range, nearest_knot_planes, random_points, random_volume};
use boxforge_runtime::volume::DeviceVolume;

fn derive(name: &str) -> Derivation {
    Derivation::new(&boxforge::spec::catalog::get(name).unwrap()).unwrap()
}

/// Runs `source` (a module for `d` with `<f>_eval_hessian`) at `pts` and tallies it.
fn tally(
    d: &Derivation,
    source: &str,
    seed: u64,
    pts: impl Fn(&boxforge_runtime::volume::LatticeVolume) -> Vec<[f32; 4]>,
) -> HessianTally {
    let gpu = crate::common::gpu();
    let vol = random_volume(d, seed);
    let dv = DeviceVolume::new(gpu, &vol, Layout::Embedded).unwrap();
    let ev = HessianEvaluator::new(gpu, source, "hessian test", &d.filter.name, &dv).unwrap();
    let points = pts(&vol);
    let got = ev.eval(&points).unwrap();
    let mut t = HessianTally::new(data_range(&vol));
    t.check(d, &vol, &points, &got);
    t
}

#[test]
fn a_mutated_hessian_coefficient_fails_the_check() {
    for name in ["bcc7", "cc_tricubic"] {
        let d = derive(name);
        let module = emit(&d, &EmitOptions { kernels: false, ..EmitOptions::default() }).unwrap().source;
        let good = tally(&d, &module, 3, |vol| random_points(&d, vol, 400, 3));
        assert!(good.passed(), "{name}: the emitted Hessian must pass: {good:?}");
        // One mixed second derivative off by 1% (both mirror entries, so the
        // matrix stays symmetric): the kind of slip a hand derivation makes.
        let ret = format!("return {name}_Hessian(");
        let at = module.find(&ret).expect("eval_hessian returns the struct");
        let end = at + module[at..].find(");").unwrap();
        let args: Vec<&str> = module[at + ret.len()..end].rsplitn(2, ", ").collect();
        let (hx, rest) = (args[0], args[1]);
        let mutated = format!(
            "{}var hm_mutated = {hx};\n    hm_mutated[0][1] = hm_mutated[0][1] * 1.01;\n    hm_mutated[1][0] = hm_mutated[1][0] * 1.01;\n    {ret}{rest}, hm_mutated{}",
            &module[..at],
            &module[end..]
        );
        let bad = tally(&d, &mutated, 3, |vol| random_points(&d, vol, 400, 3));
        assert!(!bad.passed(), "{name}: a 1% error in d2/dxdy must fail: {bad:?}");
        assert!(bad.max_rel > 10.0 * good.max_rel.max(1e-7), "{name}: {} vs {}", bad.max_rel, good.max_rel);
    }
    // Inside the generated code: one coefficient of cc_tricubic's
    // second-derivative weights (`ddwt_*`, the only place second
    // derivatives are made in the factored form) off by 1%.
    let d = derive("cc_tricubic");
    let module = emit(&d, &EmitOptions { kernels: false, ..EmitOptions::default() }).unwrap().source;
    let line =
        module.lines().find(|l| l.trim_start().starts_with("let ddwt") && l.contains("3.0 *")).expect("a ddwt weight");
    let mutated = module.replacen(line, &line.replacen("3.0 *", "3.03 *", 1), 1);
    assert_ne!(mutated, module);
    let bad = tally(&d, &mutated, 3, |vol| random_points(&d, vol, 400, 3));
    assert!(!bad.passed() && bad.max_rel > 1e-3, "a second-derivative weight off by 1% must fail: {bad:?}");
    // ... and eval and eval_grad do not see it (the weights are the Hessian's alone).
    assert!(bad.first_order.passed(), "{bad:?}");
}

#[test]
fn on_knot_planes_of_a_c1_filter_the_hessian_matches_a_side() {
    // fcc6 is C^1: its Hessian jumps across every knot plane.
    let d = derive("fcc6");
    assert_eq!(d.facts.continuity, 1);
    let module = emit(&d, &EmitOptions { kernels: false, ..EmitOptions::default() }).unwrap().source;
    let t = tally(&d, &module, 5, |vol| {
        // Random points moved onto the nearest knot plane of one family (f32
        // rounding leaves them within the knot tolerance, on either side).
        random_points(&d, vol, 600, 5)
            .into_iter()
            .enumerate()
            .map(|(i, p)| {
                let x = [p[0] as f64, p[1] as f64, p[2] as f64];
                let planes = nearest_knot_planes(&d, &x);
                let (n, c, _, _) = &planes[i % planes.len()];
                let nn: f64 = n.iter().map(|a| (*a * *a) as f64).sum();
                let t = (n.iter().zip(&x).map(|(a, b)| *a as f64 * b).sum::<f64>() - c) / nn;
                [(x[0] - t * n[0] as f64) as f32, (x[1] - t * n[1] as f64) as f32, (x[2] - t * n[2] as f64) as f32, 0.0]
            })
            .collect()
    });
    assert!(t.passed(), "{t:?}");
    assert!(t.first_order.near_knot_points >= 500, "the points lie on knot planes: {t:?}");
    // The jump is real: some device Hessians belong to the other side's piece.
    assert!(t.accepted_other_side > 0, "{t:?}");
}
