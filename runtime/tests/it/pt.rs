//! Projected tetrahedra (Mattausch et al. 2003, section 4) against the ray
//! caster: barycentric interpolation on the BCC Delaunay tetrahedra is
//! exactly the linear box spline `bcc_linear`, and on the six Kuhn
//! tetrahedra of each CC cube (around its main diagonal) the box spline with
//! directions e1, e2, e3, (1, 1, 1), so the PT image of either mesh and the
//! ray-cast DVR image of that spline show the same function and must agree.
//! (With the cell's own gradient as the normal, constant on a tetrahedron,
//! Gouraud and Phong shading coincide; both are drawn. With the paper's
//! smooth vertex normals they differ, and both stay close to the ray cast.)

use boxforge::derive::Derivation;
use boxforge::emit::Layout;
use boxforge_runtime::render::dvr::transfer::TransferFunction;
use boxforge_runtime::render::dvr::{rms, DvrOptions, DvrScene};
use boxforge_runtime::render::pt::render::{render, Normals, Shading};
use boxforge_runtime::volume::LatticeVolume;

/// Fraction of pixels away from the background (20, 20, 26) by more than
/// the f16 target's rounding of it.
fn covered(img: &[u8]) -> f64 {
    let bg = [20i32, 20, 26];
    img.chunks(4).filter(|p| (0..3).any(|c| (p[c] as i32 - bg[c]).abs() > 2)).count() as f64 / (img.len() / 4) as f64
}

#[test]
fn projected_tetrahedra_on_bcc_match_the_ray_cast_linear_box_spline() {
    let d = Derivation::new(&boxforge::spec::catalog::get("bcc_linear").unwrap()).unwrap();
    agree(&d, 32);
}

#[test]
fn projected_tetrahedra_on_cc_match_the_ray_cast_kuhn_linear_box_spline() {
    let spec = r#"name = "cc_kuhn_linear"
description = "piecewise linear on the Kuhn tetrahedra of the cubes"
lattice = "cc"
directions = [[1,0,0],[0,1,0],[0,0,1],[1,1,1]]"#;
    let d = Derivation::new(&boxforge::Filter::from_toml(spec, "test").unwrap()).unwrap();
    agree(&d, 26);
}

/// PT and the ray caster on Marschner-Lobb with about `edge`^3 samples.
fn agree(d: &Derivation, edge: usize) {
    let gpu = crate::common::gpu();
    let vol = LatticeVolume::marschner_lobb(&d.filter.lattice, [edge, edge, edge]).unwrap();
    // The preset's haze makes every cell visible; this one shows only the
    // shells around 0.5 and 0.75, so the visibility mask has cells to skip.
    let tf = TransferFunction::parse(
        r#"{"range": [0, 1], "points": [
            {"value": 0.0, "color": [0.2, 0.4, 0.9], "opacity": 0.0},
            {"value": 0.44, "color": [0.9, 0.6, 0.3], "opacity": 0.0},
            {"value": 0.5, "color": [1.0, 0.7, 0.3], "opacity": 0.6},
            {"value": 0.56, "color": [1.0, 0.7, 0.3], "opacity": 0.0},
            {"value": 0.7, "color": [0.9, 0.2, 0.2], "opacity": 0.0},
            {"value": 0.75, "color": [0.9, 0.2, 0.2], "opacity": 0.2},
            {"value": 0.8, "color": [0.9, 0.2, 0.2], "opacity": 0.0},
            {"value": 1.0, "color": [1.0, 1.0, 1.0], "opacity": 0.0}]}"#,
        "test",
    )
    .unwrap();
    for (az, el) in [(30.0, 25.0), (-120.0, -40.0)] {
        let o = DvrOptions {
            width: 96,
            height: 96,
            azimuth: az,
            elevation: el,
            step: 0.5,
            frames: 0,
            ..DvrOptions::default()
        };
        // The ray caster at a fine step (its segments converge to the integral).
        let fine = DvrOptions { step: 0.05, termination: 0.9999, ..o.clone() };
        let scene = DvrScene::new(gpu, d, &vol, Layout::Embedded, 4).unwrap();
        let reference = scene.render(&tf, &fine).unwrap();
        let mut smooth_images = Vec::new();
        for shading in [Shading::Gouraud, Shading::Phong] {
            let (frame, stats) = render(gpu, d, &vol, &tf, &o, shading, Normals::Cell).unwrap();
            let e = rms(&frame.rgba, &reference.rgba);
            eprintln!(
                "{} view ({az}, {el}) {shading:?}: PT vs ray cast RMS {e:.3}/255; {} of {} tetrahedra drawn; covered {:.2}",
                d.filter.name,
                stats.drawn,
                stats.total,
                covered(&frame.rgba)
            );
            assert!(covered(&reference.rgba) > 0.2, "the volume is in view");
            assert!((covered(&frame.rgba) - covered(&reference.rgba)).abs() < 0.01, "both show the same footprint");
            assert!(
                stats.drawn > 0 && stats.drawn < stats.total,
                "the visibility mask skips some cells and keeps some"
            );
            assert!(
                e < 3.0,
                "{} view ({az}, {el}) {shading:?}: PT vs ray cast RMS {e:.2}/255 (want < 3)",
                d.filter.name
            );
            // The paper's smooth vertex normals: only the shading changes (same
            // footprint; the lighting moves by several levels, not wholesale).
            let (smooth, _) = render(gpu, d, &vol, &tf, &o, shading, Normals::Vertex).unwrap();
            let es = rms(&smooth.rgba, &reference.rgba);
            eprintln!("  with vertex normals: RMS {es:.3}/255 against the ray cast");
            assert!(
                (covered(&smooth.rgba) - covered(&reference.rgba)).abs() < 0.01,
                "vertex normals keep the footprint"
            );
            assert!(es < 20.0, "{shading:?} with vertex normals: RMS {es:.2}/255 against the ray cast");
            smooth_images.push(smooth.rgba);
        }
        let g_p = rms(&smooth_images[0], &smooth_images[1]);
        eprintln!("  Gouraud vs Phong with vertex normals: RMS {g_p:.3}/255");
        assert!(g_p > 0.0, "Gouraud and Phong differ with vertex normals");
    }
}
