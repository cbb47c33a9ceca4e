//! Mattausch et al.'s bilinear and bilinear-plus-spatial interpolation on
//! BCC (seed 003, "Comparison of Rendering Methods for BCC Grids", sections
//! 3.1 and 3.2), hand-written once in WGSL (runtime/references/
//! mattausch_bilinear.wgsl), evaluated on the GPU at random points for every
//! plane stack and compared with an independent CPU implementation written
//! from the paper: here a plane's value is the sum of its samples weighted by
//! the bilinear hat functions, not the shader's lower-corner lookup.

use boxforge::derive::Derivation;
use boxforge::emit::{emit, EmitOptions, Layout};
use boxforge_runtime::bench::{program, Job};
use boxforge_runtime::references::MATTAUSCH_BILINEAR;
use boxforge_runtime::verify::Rng;
use boxforge_runtime::volume::DeviceVolume;
use boxforge_runtime::volume::LatticeVolume;

const N: usize = 24;

fn hat(t: f64) -> f64 {
    (1.0 - t.abs()).max(0.0)
}

/// The value of plane `m` of stack `axis` at in-plane position (u, v): every
/// BCC sample of the plane weighted by hat((u - a) / 2) hat((v - b) / 2).
fn plane(vol: &LatticeVolume, axis: usize, m: i64, u: f64, v: f64) -> f64 {
    let (ia, ib) = match axis {
        0 => (1, 2),
        1 => (0, 2),
        _ => (0, 1),
    };
    let mut sum = 0.0;
    for a in (u.floor() as i64 - 2)..=(u.ceil() as i64 + 2) {
        for b in (v.floor() as i64 - 2)..=(v.ceil() as i64 + 2) {
            let mut j = [0i64; 3];
            j[axis] = m;
            j[ia] = a;
            j[ib] = b;
            if !vol.lattice.contains(&j) {
                continue;
            }
            let w = hat((u - a as f64) / 2.0) * hat((v - b as f64) / 2.0);
            if w != 0.0 {
                let [x, y, z] = j.map(|c| c as usize);
                sum += w * vol.data[x + N * (y + N * z)] as f64;
            }
        }
    }
    sum
}

fn in_plane(p: [f64; 3], axis: usize) -> (f64, f64, f64) {
    match axis {
        0 => (p[1], p[2], p[0]),
        1 => (p[0], p[2], p[1]),
        _ => (p[0], p[1], p[2]),
    }
}

/// Section 3.1: the nearest plane's bilinear value.
fn bilinear(vol: &LatticeVolume, p: [f64; 3], axis: usize) -> f64 {
    let (u, v, w) = in_plane(p, axis);
    plane(vol, axis, (w + 0.5).floor() as i64, u, v)
}

/// Section 3.2: the planes' values weighted by hat(w - m), the linear
/// interpolation S_alpha = (1 - alpha) S_i + alpha S_i+1 between the two
/// planes around the point.
fn bilinear_spatial(vol: &LatticeVolume, p: [f64; 3], axis: usize) -> f64 {
    let (u, v, w) = in_plane(p, axis);
    let m0 = w.floor() as i64;
    (m0 - 1..=m0 + 2).map(|m| hat(w - m as f64) * plane(vol, axis, m, u, v)).sum()
}

#[test]
fn mattausch_bilinear_schemes_match_the_papers_formulas_on_every_stack() {
    let gpu = crate::common::gpu();
    let d = Derivation::new(&boxforge::spec::catalog::get("bcc_linear").unwrap()).unwrap();
    let mut rng = Rng(41);
    let data = (0..N * N * N)
        .map(|i| {
            let j = [(i % N) as i64, ((i / N) % N) as i64, (i / (N * N)) as i64];
            if d.filter.lattice.contains(&j) {
                rng.next_f64() as f32
            } else {
                0.0
            }
        })
        .collect();
    let vol = LatticeVolume { lattice: d.filter.lattice.clone(), dims: [N, N, N], data };
    // Points well inside, so no stencil reaches the clamped border.
    let points: Vec<[f32; 4]> = (0..2000)
        .map(|_| {
            let mut c = || (4.0 + (N as f64 - 9.0) * rng.next_f64()) as f32;
            [c(), c(), c(), 0.0]
        })
        .collect();
    let module = emit(&d, &EmitOptions { kernels: false, ..Default::default() }).unwrap().source;
    let dv = DeviceVolume::new(gpu, &vol, Layout::Embedded).unwrap();
    type Cpu = fn(&LatticeVolume, [f64; 3], usize) -> f64;
    let schemes: [(&str, Cpu); 2] =
        [("mattausch_bilinear", bilinear), ("mattausch_bilinear_spatial", bilinear_spatial)];
    for (entry, cpu) in schemes {
        for axis in 0..3 {
            let call = format!("vec4<f32>({entry}(p, {axis}), 0.0, 0.0, 0.0)");
            let job = Job::new(gpu, &program(&module, MATTAUSCH_BILINEAR, &call), entry, &dv, &points).unwrap();
            job.time(gpu).unwrap();
            let out = job.outputs(gpu).unwrap();
            let mut worst = 0f64;
            for (p, o) in points.iter().zip(&out) {
                let x = [p[0] as f64, p[1] as f64, p[2] as f64];
                // Skip points within f32 rounding of the nearest-plane switch (w = m + 1/2).
                let w = in_plane(x, axis).2;
                if entry == "mattausch_bilinear" && ((w - w.floor()) - 0.5).abs() < 1e-5 {
                    continue;
                }
                worst = worst.max((o[0] as f64 - cpu(&vol, x, axis)).abs());
            }
            // Data in [0, 1): the range is (at most) 1.
            assert!(worst < 1e-6, "{entry} on stack {axis}: max |GPU - CPU| = {worst:.3e} (want < 1e-6 of the range)");
            eprintln!("{entry} on stack {axis}: max |GPU - CPU| = {worst:.2e} at {} points", points.len());
        }
    }
}

// ---- Ray cast (`render --mode dvr --filter mattausch_bilinear[_spatial]`) ----

use boxforge_runtime::render::dvr::transfer::TransferFunction;
use boxforge_runtime::render::dvr::{rms, DvrOptions, DvrScene};
use boxforge_runtime::render::schemes::{self, Scheme};

/// An affine function sampled on BCC: bilinear plus spatial and barycentric
/// (bcc_linear) both reproduce it, so their DVR images must agree.
fn affine_bcc(n: usize, slope: f64) -> LatticeVolume {
    let lattice = boxforge::spec::lattice::Lattice::builtin("bcc").unwrap();
    let mut data = vec![0.0f32; n * n * n];
    for z in 0..n {
        for y in 0..n {
            for x in 0..n {
                let j = [x as i64, y as i64, z as i64];
                if lattice.contains(&j) {
                    data[x + n * (y + n * z)] = (slope * (1.0 * x as f64 + 0.75 * y as f64 + 0.5 * z as f64)) as f32;
                }
            }
        }
    }
    LatticeVolume { lattice, dims: [n; 3], data }
}

fn slab_tf() -> TransferFunction {
    TransferFunction::parse(
        r#"{"range": [0, 1], "points": [{"value": 0, "color": [0, 0, 0], "opacity": 0},
            {"value": 0.3, "color": [0.2, 0.5, 0.9], "opacity": 0}, {"value": 0.4, "color": [1, 0.8, 0.3], "opacity": 0.6},
            {"value": 0.5, "color": [0.9, 0.2, 0.1], "opacity": 0}, {"value": 1, "color": [0, 0, 0], "opacity": 0}]}"#,
        "slab",
    )
    .unwrap()
}

#[test]
fn ray_cast_bilinear_spatial_reproduces_an_affine_volume_like_barycentric() {
    let gpu = crate::common::gpu();
    let vol = affine_bcc(20, 0.02);
    let base = schemes::base().unwrap();
    let tf = slab_tf();
    let o = DvrOptions { width: 64, height: 64, frames: 0, step: 0.25, ..DvrOptions::default() };
    let reference = DvrScene::new(gpu, &base, &vol, Layout::Embedded, 4).unwrap().render(&tf, &o).unwrap();
    let (frame, choice) = schemes::render(gpu, &vol, Scheme::BilinearSpatial, &tf, &o).unwrap();
    let e = rms(&frame.rgba, &reference.rgba);
    eprintln!("{choice}; RMS vs bcc_linear {e:.3}/255");
    assert!(e < 1.0, "bilinear + spatial vs barycentric on an affine volume: RMS {e:.3}/255");
    // Nearest-plane bilinear does not reproduce the part across the planes: it can fail.
    let (frame, _) = schemes::render(gpu, &vol, Scheme::Bilinear, &tf, &o).unwrap();
    let e_nearest = rms(&frame.rgba, &reference.rgba);
    eprintln!("nearest-plane bilinear: RMS vs bcc_linear {e_nearest:.3}/255");
    assert!(e_nearest > 4.0 * e.max(0.1), "nearest-plane bilinear RMS {e_nearest:.3}/255");
}

#[test]
fn ray_cast_schemes_pick_the_stack_from_the_view_and_skip_exactly() {
    let gpu = crate::common::gpu();
    let base = schemes::base().unwrap();
    let vol = LatticeVolume::marschner_lobb(&base.filter.lattice, [N, N, N]).unwrap();
    let tf = TransferFunction::preset("marschner-lobb");
    for scheme in schemes::ALL {
        // Looking down z (elevation 80): the z stack, and not the x stack.
        let o =
            DvrOptions { width: 48, height: 48, frames: 0, azimuth: 20.0, elevation: 80.0, ..DvrOptions::default() };
        let (frame, choice) = schemes::render(gpu, &vol, scheme, &tf, &o).unwrap();
        assert!(choice.contains("plane stack along z"), "{choice}");
        let stack =
            |axis: usize| schemes::scene(gpu, &base, &vol, scheme, axis, o.block).unwrap().render(&tf, &o).unwrap();
        let (z, x) = (stack(2), stack(0));
        assert_eq!(rms(&frame.rgba, &z.rgba), 0.0, "{}: the chosen stack is z", scheme.name());
        let other = rms(&frame.rgba, &x.rgba);
        assert!(other > 0.5, "{}: the x stack gives another image (RMS {other:.2}/255)", scheme.name());
        // Empty-space skipping with the widened bounds changes nothing (a
        // slab of an affine volume: many blocks are transparent).
        let slab = slab_tf();
        let affine = affine_bcc(40, 0.0107);
        let skip = schemes::scene(gpu, &base, &affine, scheme, 2, o.block).unwrap();
        let a = skip.render(&slab, &o).unwrap();
        let b = skip.render(&slab, &DvrOptions { skip: false, ..o.clone() }).unwrap();
        let e = rms(&a.rgba, &b.rgba);
        eprintln!(
            "{}: {choice}; x stack RMS {other:.2}/255; skip vs no skip {e:.4}/255, {:.0}% of blocks empty",
            scheme.name(),
            a.empty_blocks * 100.0
        );
        assert!(a.empty_blocks > 0.1 && e < 0.01, "{}: skipping changed the image by {e:.3}/255", scheme.name());
    }
}
