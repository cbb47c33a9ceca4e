//! Curvature shading (`render --shade`): every mode on the device against
//! the CPU reference ray caster, whose colours come from the exact
//! evaluator's Hessian in f64 (RMS < 1/255 over the pixels where both
//! found the same hit, which must be at least 99% of them: a ray grazing the
//! surface may find its crossing one step apart in f32 and in f64).

use boxforge::derive::Derivation;
use boxforge::emit::Layout;
use boxforge_runtime::render::iso::{
    cpu_render_with_depth, render, render_with_depth, RenderOptions, Shade, ShadeMode,
};
use boxforge_runtime::volume::LatticeVolume;

fn is_hit(px: &[u8]) -> bool {
    !(px[0] == 20 && px[1] == 20 && px[2] == 26)
}

/// (fraction of pixels whose hit/miss differ, RMS channel difference in
/// units of 1/255 over the pixels hit in both at the same depth (within
/// 1e-3 cell), those pixels, the pixels hit in both).
fn compare(a: &[u8], da: &[f32], b: &[u8], db: &[f32]) -> (f64, f64, usize, usize) {
    let n = a.len() / 4;
    let (mut mismatch, mut both, mut same, mut sq) = (0, 0, 0, 0.0);
    for i in 0..n {
        let (pa, pb) = (&a[i * 4..i * 4 + 4], &b[i * 4..i * 4 + 4]);
        if is_hit(pa) != is_hit(pb) {
            mismatch += 1;
        } else if is_hit(pa) {
            both += 1;
            if (da[i] - db[i]).abs() < 1e-3 {
                same += 1;
                sq += (0..3).map(|c| (pa[c] as f64 - pb[c] as f64).powi(2)).sum::<f64>() / 3.0;
            }
        }
    }
    (mismatch as f64 / n as f64, (sq / same.max(1) as f64).sqrt(), same, both)
}

#[test]
fn every_curvature_mode_matches_the_cpu_reference() {
    let gpu = crate::common::gpu();
    for (name, edge) in [("bcc7", 30), ("cc_tricubic", 26)] {
        let d = Derivation::new(&boxforge::spec::catalog::get(name).unwrap()).unwrap();
        let vol = LatticeVolume::marschner_lobb(&d.filter.lattice, [edge, edge, edge]).unwrap();
        let mut images = Vec::new();
        for mode in ShadeMode::ALL.into_iter().filter(|m| m.needs_hessian()) {
            let o = RenderOptions {
                width: 40,
                height: 40,
                frames: 1,
                shade: Shade { mode, radius: 3.0, thickness: 1.5 },
                ..RenderOptions::default()
            };
            let (frame, depth) = render_with_depth(gpu, &d, &vol, Layout::Embedded, &o).unwrap();
            let (reference, ref_depth) = cpu_render_with_depth(&d, &vol, &o);
            let (mismatch, rms, same, both) = compare(&frame.rgba, &depth, &reference, &ref_depth);
            assert!(both > 150, "{name} {mode:?}: the surface is in view ({both} pixels)");
            assert!(same as f64 >= 0.99 * both as f64, "{name} {mode:?}: {same} of {both} hits at the same depth");
            assert!(mismatch <= 0.01, "{name} {mode:?}: {:.2}% of pixels differ in hit/miss", mismatch * 100.0);
            assert!(rms < 1.0, "{name} {mode:?}: RMS {rms:.3}/255");
            images.push(reference);
        }
        // The modes colour differently (each one is a different picture).
        for i in 0..images.len() {
            for j in i + 1..images.len() {
                assert_ne!(images[i], images[j], "{name}: modes {i} and {j}");
            }
        }
    }
}

#[test]
fn curvature_needs_a_filter_of_degree_two() {
    let gpu = crate::common::gpu();
    let d = Derivation::new(&boxforge::spec::catalog::get("bcc_linear").unwrap()).unwrap();
    let vol = LatticeVolume::marschner_lobb(&d.filter.lattice, [12, 12, 12]).unwrap();
    let o = RenderOptions {
        width: 8,
        height: 8,
        frames: 1,
        shade: Shade { mode: ShadeMode::Mean, ..Shade::default() },
        ..RenderOptions::default()
    };
    let e = render(gpu, &d, &vol, Layout::Embedded, &o).err().expect("bcc_linear has no Hessian");
    assert!(e.to_string().contains("degree 1"), "{e}");
}

/// `render --mode dvr --tf-curvature`: the curvature transfer function on
/// the device against the CPU reference (f64 Hessian), and it changes the picture.
#[test]
fn the_curvature_transfer_function_matches_the_cpu_reference() {
    use boxforge_runtime::render::dvr::{cpu_render as dvr_cpu, render as dvr_render, rms, DvrOptions};
    let gpu = crate::common::gpu();
    let d = Derivation::new(&boxforge::spec::catalog::get("bcc7").unwrap()).unwrap();
    let vol = LatticeVolume::marschner_lobb(&d.filter.lattice, [24, 24, 24]).unwrap();
    let tf = boxforge_runtime::render::dvr::transfer::TransferFunction::preset("marschner-lobb");
    let o = DvrOptions { width: 32, height: 32, frames: 1, curvature: Some(3.0), ..DvrOptions::default() };
    let frame = dvr_render(gpu, &d, &vol, Layout::Embedded, &tf, &o).unwrap();
    let reference = dvr_cpu(&d, &vol, &tf, &o);
    let r = rms(&frame.rgba, &reference);
    assert!(r < 1.0, "RMS {r:.3}/255");
    let plain = dvr_cpu(&d, &vol, &tf, &DvrOptions { curvature: None, ..o.clone() });
    assert!(rms(&plain, &reference) > 5.0, "the curvature transfer function colours the volume");
}
