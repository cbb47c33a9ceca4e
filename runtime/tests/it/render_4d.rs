//! Time-varying volumes (issue #29): an isosurface of the drifting
//! Marschner-Lobb space-time signal at a time between two frames, drawn by
//! evaluating the 4D spline at (x, y, z, t) on the device, equals the exact
//! evaluator's frame (f64) and is not the frame of the linear blend of the
//! two sampled frames, which is what a viewer interpolating its 3D frames
//! would show.

use boxforge::derive::Derivation;
use boxforge::emit::Layout;
use boxforge_runtime::render::four::{compare, cpu_reference, FourIsoOptions, FourIsoRenderer};
use boxforge_runtime::volume::{LatticeVolume4, VolumeSeries};

/// The linear blend of the frames around `t`, as every frame of a series
/// on Z^4: through a tensor-product spline, the 3D spline of the blend.
fn blend_in_every_frame(series: &VolumeSeries, t: f64) -> LatticeVolume4 {
    let blend = series.blend(t);
    let data: Vec<f32> = (0..series.frames()).flat_map(|_| blend.data.iter().copied()).collect();
    let vol = LatticeVolume4::from_series(series);
    LatticeVolume4::new(vol.lattice, vol.dims, data).unwrap()
}

#[test]
fn an_isosurface_between_frames_is_the_4d_spline_not_the_blend() {
    let gpu = crate::common::gpu();
    let d = Derivation::new(&boxforge::spec::catalog::get("z4_cubic").unwrap()).unwrap();
    let series = VolumeSeries::marschner_lobb_drift([20, 20, 20, 6]).unwrap();
    let vol = LatticeVolume4::from_series(&series);
    let o = FourIsoOptions { width: 32, height: 32, ..FourIsoOptions::default() };
    let t = 2.5;
    let embedded = FourIsoRenderer::new(gpu, &d, &vol, Layout::Embedded).unwrap().render(t, &o).unwrap();
    let hits = embedded.chunks(4).filter(|p| p[0] > 0).count();
    assert!(hits > 100, "the surface covers part of the frame ({hits} of 1024 pixels)");
    // The exact 4D reference.
    let exact = cpu_reference(&d, &vol, t as f64, &o);
    let (rms, one_sided, _) = compare(&embedded, &exact);
    assert!(
        rms < 1.0 / 255.0 && one_sided <= 16,
        "against the exact frame: RMS {rms:.2e}, {one_sided} pixels hit by one"
    );
    // The packed layout draws the same frame.
    let packed = FourIsoRenderer::new(gpu, &d, &vol, Layout::Packed).unwrap().render(t, &o).unwrap();
    let (rms_p, one_p, _) = compare(&embedded, &packed);
    assert!(rms_p < 1.0 / 255.0 && one_p <= 4, "packed: {rms_p:.2e}, {one_p}");
    // The blend of frames 2 and 3, constant in time, through the same spline:
    // the tricubic frame of the blended volume.
    let blended = blend_in_every_frame(&series, t as f64);
    let blend_frame = FourIsoRenderer::new(gpu, &d, &blended, Layout::Embedded).unwrap().render(t, &o).unwrap();
    let (_, _, rms_blend) = compare(&embedded, &blend_frame);
    assert!(rms_blend > 1.0 / 255.0, "the blend's frame differs: RMS {rms_blend:.2e}");
    eprintln!(
        "4D iso at t = {t}: {hits} hits; vs exact RMS {rms:.2e} ({one_sided} one-sided); vs the blend RMS {rms_blend:.2e}"
    );
}

/// `boxforge render` with a 4D filter: one frame at a time between samples
/// (exact hits),
/// an animation of numbered PNGs, and one-line refusals (exit 2, nothing
/// written) for what it does not do.
#[test]
fn render_cli_draws_time_series() {
    let bin = env!("CARGO_BIN_EXE_boxforge");
    let dir = std::env::temp_dir().join(format!("boxforge-render-4d-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let run = |args: &[&str]| std::process::Command::new(bin).args(args).output().unwrap();
    let one = dir.as_path().join("t.png");
    let out = run(&[
        "render",
        "--filter",
        "z4_linear",
        "--volume",
        "ml-drift:16,4",
        "--time",
        "1.5",
        "--hit",
        "exact",
        "--size",
        "32",
        "--out",
        one.to_str().unwrap(),
    ]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    assert!(std::fs::metadata(&one).unwrap().len() > 0);
    let anim = dir.as_path().join("a.png");
    let out = run(&[
        "render",
        "--filter",
        "z4_linear",
        "--volume",
        "ml-drift:16,4",
        "--frames",
        "2",
        "--size",
        "16",
        "--out",
        anim.to_str().unwrap(),
    ]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    assert!(dir.as_path().join("a-0000.png").exists() && dir.as_path().join("a-0001.png").exists());
    // DVR with the default ramp and with a preset.
    for tf in [None, Some("marschner-lobb")] {
        let dvr = dir.as_path().join("v.png");
        let mut args =
            vec!["render", "--filter", "z4_linear", "--volume", "ml-drift:16,4", "--mode", "dvr", "--time", "0.5"];
        if let Some(tf) = tf {
            args.extend_from_slice(&["--tf", tf]);
        }
        args.extend_from_slice(&["--size", "16", "--out", dvr.to_str().unwrap()]);
        let out = run(&args);
        assert!(out.status.success() && dvr.exists(), "{tf:?}: {}", String::from_utf8_lossy(&out.stderr));
        std::fs::remove_file(&dvr).unwrap();
    }
    // D4*: the signal sampled on the lattice at the matched count.
    let d4s = dir.as_path().join("d.png");
    let out = run(&[
        "render",
        "--filter",
        "d4star8",
        "--volume",
        "ml-drift:12,4",
        "--time",
        "1.5",
        "--layout",
        "packed",
        "--size",
        "16",
        "--out",
        d4s.to_str().unwrap(),
    ]);
    assert!(out.status.success() && d4s.exists(), "{}", String::from_utf8_lossy(&out.stderr));
    let bad = dir.as_path().join("bad.png");
    for args in [
        &["--filter", "z4_linear", "--volume", "ml-drift:16,4", "--time", "7"][..],
        &["--filter", "z4_linear", "--volume", "ml-drift:16,4", "--hit", "exact", "--mode", "dvr"],
        &["--filter", "d4star8", "--volume", "ml-drift:16,4", "--layout", "bricked"],
        &["--filter", "bcc7", "--volume", "ml:16", "--time", "1"],
        &["--filter", "z4_linear", "--volume", "ml-drift:16"],
    ] {
        let mut all = vec!["render"];
        all.extend_from_slice(args);
        all.extend_from_slice(&["--out", bad.to_str().unwrap()]);
        let out = run(&all);
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{args:?}: {err}");
        assert_eq!(err.trim().lines().count(), 1, "{args:?}: {err}");
        assert!(!bad.exists(), "{args:?} wrote a file");
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// The same for direct volume rendering: the DVR frame between frames
/// equals the exact evaluator's (same steps, lookup and early stop) and is
/// not the blend's.
#[test]
fn a_dvr_frame_between_frames_is_the_4d_spline_not_the_blend() {
    use boxforge_runtime::render::dvr::transfer::TransferFunction;
    use boxforge_runtime::render::four::{cpu_reference_dvr, rms_rgb};
    let gpu = crate::common::gpu();
    let d = Derivation::new(&boxforge::spec::catalog::get("z4_cubic").unwrap()).unwrap();
    let series = VolumeSeries::marschner_lobb_drift([20, 20, 20, 6]).unwrap();
    let vol = LatticeVolume4::from_series(&series);
    let o = FourIsoOptions { width: 32, height: 32, step: 0.5, ..FourIsoOptions::default() };
    let tf = TransferFunction::preset("marschner-lobb").table();
    let t = 2.5;
    let frame = FourIsoRenderer::new(gpu, &d, &vol, Layout::Embedded).unwrap().render_dvr(t, &o, &tf).unwrap();
    let lit = frame.chunks(4).filter(|p| p[0] as u32 + p[1] as u32 + p[2] as u32 > 30).count();
    assert!(lit > 100, "the volume shows ({lit} of 1024 pixels lit)");
    let exact = cpu_reference_dvr(&d, &vol, t as f64, &o, &tf);
    let rms = rms_rgb(&frame, &exact);
    assert!(rms < 1.0 / 255.0, "against the exact frame: RMS {rms:.2e}");
    let blended = blend_in_every_frame(&series, t as f64);
    let bf = FourIsoRenderer::new(gpu, &d, &blended, Layout::Embedded).unwrap().render_dvr(t, &o, &tf).unwrap();
    let rms_blend = rms_rgb(&frame, &bf);
    assert!(rms_blend > 1.0 / 255.0, "the blend's frame differs: RMS {rms_blend:.2e}");
    eprintln!("4D DVR at t = {t}: {lit} lit; vs exact RMS {rms:.2e}; vs the blend RMS {rms_blend:.2e}");
}

/// The exact-hit mode: each ray is cut where the 4D knot planes meet the
/// frame's time, and every polynomial piece is searched for its first root.
/// The device's frame equals the exact evaluator's walk on Z^4 (grid planes
/// only) and on D4* (knot planes slanted in time, whose traces move with t),
/// at a time between samples. (That such frames are not the blend's is the
/// fixed-step test's: both modes find the same surface.)
#[test]
fn exact_hits_between_frames_follow_the_4d_knot_planes() {
    use boxforge_runtime::render::four::cpu_reference_exact;
    let gpu = crate::common::gpu();
    let o = FourIsoOptions { width: 24, height: 24, exact: true, ..FourIsoOptions::default() };
    let check = |name: &str, vol: &LatticeVolume4, layout: Layout, t: f32| {
        let d = Derivation::new(&boxforge::spec::catalog::get(name).unwrap()).unwrap();
        let frame = FourIsoRenderer::new(gpu, &d, vol, layout).unwrap().render(t, &o).unwrap();
        let hits = frame.chunks(4).filter(|p| p[0] > 0).count();
        assert!(hits > 60, "{name}: the surface covers part of the frame ({hits} of 576 pixels)");
        let exact = cpu_reference_exact(&d, vol, t as f64, &o);
        let (rms, one_sided, _) = compare(&frame, &exact);
        assert!(
            rms < 1.0 / 255.0 && one_sided <= 6,
            "{name} against the exact walk: RMS {rms:.2e}, {one_sided} pixels hit by one"
        );
        eprintln!(
            "4D exact hit, {name} at t = {t}: {hits} hits; vs the exact walk RMS {rms:.2e} ({one_sided} one-sided)"
        );
    };
    let series = VolumeSeries::marschner_lobb_drift([16, 16, 16, 5]).unwrap();
    check("z4_cubic", &LatticeVolume4::from_series(&series), Layout::Embedded, 2.5);
    let lattice = boxforge::spec::catalog::get("d4star8").unwrap().lattice;
    let (vol, _) = LatticeVolume4::marschner_lobb_drift(&lattice, 14, 4).unwrap();
    check("d4star8", &vol, Layout::Packed, 2.5);
}
