//! Rendering on the device against a CPU reference ray caster, determinism,
//! and empty-space skipping that changes speed but not the image.

use boxforge::derive::Derivation;
use boxforge::emit::Layout;
use boxforge_runtime::gpu::Gpu;
use boxforge_runtime::render::iso::{cpu_render, render, RenderOptions};
use boxforge_runtime::volume::LatticeVolume;

fn setup(name: &str, edge: usize) -> (&'static Gpu, Derivation, LatticeVolume) {
    let gpu = crate::common::gpu();
    let d = Derivation::new(&boxforge::spec::catalog::get(name).unwrap()).unwrap();
    let vol = LatticeVolume::marschner_lobb(&d.filter.lattice, [edge, edge, edge]).unwrap();
    (gpu, d, vol)
}

fn is_hit(px: &[u8]) -> bool {
    // Background is (0.08, 0.08, 0.1) -> (20, 20, 26).
    !(px[0] == 20 && px[1] == 20 && px[2] == 26)
}

/// (fraction of pixels whose hit/miss differ, mean abs channel difference over pixels hit in both).
fn compare(a: &[u8], b: &[u8]) -> (f64, f64) {
    let n = a.len() / 4;
    let mut mismatch = 0;
    let mut diff = 0.0;
    let mut both = 0;
    for i in 0..n {
        let (pa, pb) = (&a[i * 4..i * 4 + 4], &b[i * 4..i * 4 + 4]);
        if is_hit(pa) != is_hit(pb) {
            mismatch += 1;
        } else if is_hit(pa) {
            both += 1;
            diff += (0..3).map(|c| (pa[c] as f64 - pb[c] as f64).abs()).sum::<f64>() / 3.0;
        }
    }
    (mismatch as f64 / n as f64, diff / both.max(1) as f64)
}

#[test]
fn gpu_image_matches_the_cpu_reference_ray_cast() {
    for (name, edge, perspective) in [("bcc7", 36, false), ("fcc6", 30, true)] {
        let (gpu, d, vol) = setup(name, edge);
        let o = RenderOptions { width: 64, height: 64, perspective, frames: 1, ..RenderOptions::default() };
        let frame = render(gpu, &d, &vol, Layout::Embedded, &o).unwrap();
        let reference = cpu_render(&d, &vol, &o);
        let hits = reference.chunks(4).filter(|p| is_hit(p)).count();
        assert!(hits > 200, "{name}: the surface is in view ({hits} pixels)");
        let (mismatch, shading) = compare(&frame.rgba, &reference);
        assert!(mismatch <= 0.01, "{name}: {:.2}% of pixels differ in hit/miss", mismatch * 100.0);
        assert!(shading < 3.0, "{name}: mean shading difference {shading:.2}/255");
    }
}

#[test]
fn same_input_same_image_and_skipping_does_not_change_it() {
    let (gpu, d, vol) = setup("bcc7", 36);
    let o = RenderOptions { width: 64, height: 64, frames: 1, ..RenderOptions::default() };
    let a = render(gpu, &d, &vol, Layout::Embedded, &o).unwrap();
    let b = render(gpu, &d, &vol, Layout::Embedded, &o).unwrap();
    assert_eq!(a.rgba, b.rgba, "deterministic");
    assert!(a.empty_blocks > 0.2, "Marschner-Lobb has empty blocks ({:.2})", a.empty_blocks);
    let no_skip = render(gpu, &d, &vol, Layout::Embedded, &RenderOptions { skip: false, ..o.clone() }).unwrap();
    let (mismatch, shading) = compare(&a.rgba, &no_skip.rgba);
    assert!(mismatch <= 0.01 && shading < 1.0, "skipping changed the image: {mismatch} {shading}");
    let packed = render(gpu, &d, &vol, Layout::Packed, &o).unwrap();
    let (mismatch, shading) = compare(&a.rgba, &packed.rgba);
    assert!(mismatch <= 0.01 && shading < 1.0, "packed differs from embedded: {mismatch} {shading}");
}

#[test]
fn block_bounds_contain_the_spline() {
    // The min/max grid must bound every value inside its blocks: render with
    // iso-values just outside a block's range would otherwise skip surface.
    // fcc6 bounds by BB coefficients, cc_tricubic through its factorisation.
    for name in ["fcc6", "cc_tricubic"] {
        let (gpu, d, vol) = setup(name, 24);
        let o = RenderOptions { width: 48, height: 48, frames: 1, iso: 0.3, ..RenderOptions::default() };
        let with = render(gpu, &d, &vol, Layout::Embedded, &o).unwrap();
        let without = render(gpu, &d, &vol, Layout::Embedded, &RenderOptions { skip: false, ..o.clone() }).unwrap();
        let (mismatch, _) = compare(&with.rgba, &without.rgba);
        assert!(mismatch <= 0.01, "{name}: {mismatch}");
    }
}

/// The image of `o` with skipping by the distance map, one block at a time,
/// and (testing) a map one block too far, each against no skipping:
/// (mismatch, shading) as [`compare`] gives them.
fn skip_modes(
    gpu: &Gpu,
    d: &Derivation,
    vol: &LatticeVolume,
    o: &RenderOptions,
) -> [((f64, f64), boxforge_runtime::render::iso::Frame); 3] {
    use boxforge_runtime::render::blocks::SkipMap;
    let no_skip = render(gpu, d, vol, Layout::Embedded, &RenderOptions { skip: false, ..o.clone() }).unwrap();
    [SkipMap::Distance, SkipMap::OneBlock, SkipMap::Overshoot].map(|skip_map| {
        let f = render(gpu, d, vol, Layout::Embedded, &RenderOptions { skip_map, ..o.clone() }).unwrap();
        (compare(&f.rgba, &no_skip.rgba), f)
    })
}

#[test]
fn distance_skipping_keeps_the_image_and_a_map_one_block_too_far_is_caught() {
    // Marschner-Lobb (dense: short jumps) and two small balls in an empty
    // volume (sparse: jumps over boxes of many blocks), fixed steps.
    let gpu = crate::common::gpu();
    let d = Derivation::new(&boxforge::spec::catalog::get("cc_tricubic").unwrap()).unwrap();
    let ml = LatticeVolume::marschner_lobb(&d.filter.lattice, [36; 3]).unwrap();
    let sparse = LatticeVolume::subset(&d.filter.lattice, &crate::common::sparse_balls(48)).unwrap();
    for (what, vol, perspective) in
        [("Marschner-Lobb", &ml, false), ("sparse", &sparse, true), ("sparse", &sparse, false)]
    {
        let o = RenderOptions { width: 64, height: 64, frames: 1, perspective, ..RenderOptions::default() };
        let [(exact, f), (one, _), (wrong, _)] = skip_modes(gpu, &d, vol, &o);
        let map = f.skip_map.expect("a distance map");
        eprintln!(
            "{what} (perspective {perspective}): distance {exact:?}, one block {one:?}, overshoot {wrong:?}; \
             {:.0}% empty, mean skip distance {:.2}",
            f.empty_blocks * 100.0,
            map.mean_distance
        );
        assert!(exact.0 <= 0.01 && exact.1 < 1.0, "{what}: distance skipping changed the image: {exact:?}");
        assert!(one.0 <= 0.01 && one.1 < 1.0, "{what}: one-block skipping changed the image: {one:?}");
        // The comparison can fail: a map one block too far skips surface.
        assert!(!(wrong.0 <= 0.01 && wrong.1 < 1.0), "{what}: a wrong distance map went unnoticed: {wrong:?}");
        if what == "sparse" {
            assert!(f.empty_blocks > 0.8 && map.mean_distance > 2.0, "{what}: the jumps span several blocks");
        }
    }
}
