//! Four dimensions on the device (lavapipe in CI): every 4D catalog filter in
//! both layouts that apply (embedded and coset-packed storage buffers), fast
//! variant: eval, eval_grad and eval_hessian against the exact evaluator
//! (f64) within the 3D tolerances; and the check fails on wrong data.

use boxforge::derive::Derivation;
use boxforge::emit::{Bounds, Layout, Variant};
use boxforge_runtime::verify::four::{random_points4, random_volume4, Evaluator4, Tally4};
use boxforge_runtime::verify::verify;
use boxforge_runtime::volume::{DeviceVolume4, LatticeVolume4};

fn four_d_catalog() -> Vec<Derivation> {
    boxforge::spec::catalog::names()
        .into_iter()
        .map(|n| Derivation::new(&boxforge::spec::catalog::get(n).unwrap()).unwrap())
        .filter(|d| d.facts.dim == 4)
        .collect()
}

#[test]
fn every_4d_catalog_filter_matches_the_exact_evaluator_on_the_device() {
    let gpu = crate::common::gpu();
    let filters = four_d_catalog();
    assert!(filters.len() >= 3, "the catalog has the 4D filters of issue #29");
    let mut failures = Vec::new();
    for d in &filters {
        for layout in [Layout::Embedded, Layout::Packed] {
            let r = verify(gpu, d, layout, Variant::Fast, 600, 11).unwrap();
            eprintln!(
                "{} {layout:?}: form {:?}, value {:.2e} grad {:.2e} hessian {:?}",
                d.filter.name, r.form, r.max_abs_err, r.max_rel_grad_err, r.max_rel_hessian_err
            );
            assert_eq!(r.max_rel_hessian_err.is_some(), d.facts.degree >= 2, "{}", d.filter.name);
            if !r.passed {
                failures.push(format!("{} {layout:?}: {r:?}", d.filter.name));
            }
        }
    }
    assert!(failures.is_empty(), "{failures:#?}");
}

/// The same points on the same module against data 1% off fail, in both
/// layouts; and an unchecked-bounds module agrees inside the volume.
#[test]
fn verification_in_4d_can_fail() {
    let gpu = crate::common::gpu();
    let d = Derivation::new(&boxforge::spec::catalog::get("z4_cubic").unwrap()).unwrap();
    let vol = random_volume4(&d, 3);
    let pts = random_points4(&d, &vol, 300, 3);
    let off = LatticeVolume4::new(vol.lattice.clone(), vol.dims, vol.data.iter().map(|v| v * 1.01).collect()).unwrap();
    for layout in [Layout::Embedded, Layout::Packed] {
        for bounds in [Bounds::Clamp, Bounds::Unchecked] {
            let dv = DeviceVolume4::new(gpu, &vol, layout).unwrap();
            let ev = Evaluator4::new(gpu, &d, &dv, Variant::Fast, None, bounds).unwrap();
            let got = ev.eval(&pts).unwrap();
            let t = Tally4::check(&d, &vol, &pts, &got, true);
            assert!(t.passed(), "{layout:?} {bounds:?}: {t:?}");
            let wrong = Tally4::check(&d, &off, &pts, &got, true);
            assert!(!wrong.passed() && wrong.max_abs > 1e-3, "{layout:?} {bounds:?}: {wrong:?}");
        }
    }
}

/// What 4D samples cannot do is refused with one line naming the fix.
#[test]
fn bricked_4d_volumes_are_refused_with_the_fix() {
    let gpu = crate::common::gpu();
    let d = Derivation::new(&boxforge::spec::catalog::get("z4_linear").unwrap()).unwrap();
    let vol = random_volume4(&d, 1);
    for layout in [Layout::Bricked, Layout::BrickedPacked] {
        let e = DeviceVolume4::new(gpu, &vol, layout).err().expect("refused").to_string();
        assert!(e.contains("the embedded or packed layout") && !e.contains('\n'), "{e}");
        let e = verify(gpu, &d, layout, Variant::Fast, 10, 1).unwrap_err().to_string();
        assert!(e.contains("storage buffer") && !e.contains('\n'), "{e}");
    }
}

/// `boxforge verify` takes a 4D filter: it passes on the device, and what a
/// storage buffer cannot do exits 2 with one line.
#[test]
fn verify_cli_runs_4d_filters_and_refuses_what_they_cannot_do() {
    let bin = env!("CARGO_BIN_EXE_boxforge");
    let run = |args: &[&str]| std::process::Command::new(bin).args(args).output().unwrap();
    let ok = run(&["verify", "--filter", "z4_linear", "--layout", "packed", "--points", "300"]);
    let text = String::from_utf8_lossy(&ok.stdout);
    assert!(ok.status.success() && text.contains("PASSED") && text.contains("eval_hessian"), "{text}");
    for args in [
        &["verify", "--filter", "z4_linear", "--layout", "bricked", "--points", "10"][..],
        &["verify", "--filter", "z4_linear", "--fetch", "linear", "--layout", "packed", "--points", "10"],
        &["verify", "--filter", "z4_linear", "--target", "glsl", "--points", "10"],
    ] {
        let out = run(args);
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{args:?}: {err}");
        assert_eq!(err.trim().lines().count(), 1, "{args:?}: {err}");
    }
}
