//! Exact first hit (`HitMode::Exact`): the device walk against its CPU
//! reference in f64, and thin features that fixed steps miss.

use boxforge::derive::Derivation;
use boxforge::emit::Layout;
use boxforge_runtime::bench::hit::{misses, thin_shell_scene};
use boxforge_runtime::render::iso::{cpu_render_with_depth, render_with_depth, HitMode, RenderOptions};
use boxforge_runtime::volume::LatticeVolume;

fn derive(name: &str) -> Derivation {
    Derivation::new(&boxforge::spec::catalog::get(name).unwrap()).unwrap()
}

fn exact(o: &RenderOptions) -> RenderOptions {
    RenderOptions { hit: HitMode::Exact, ..o.clone() }
}

/// Largest |t - t_ref| over pixels hit in both.
fn max_depth_diff(a: &[f32], b: &[f32]) -> f32 {
    a.iter().zip(b).filter(|(x, y)| **x >= 0.0 && **y >= 0.0).map(|(x, y)| (x - y).abs()).fold(0.0, f32::max)
}

#[test]
fn exact_hits_on_a_thin_shell_miss_nothing_that_fixed_steps_miss() {
    let gpu = crate::common::gpu();
    for (name, edge) in [("bcc7", 28), ("cc_tricubic", 24), ("fcc6", 24), ("bcc_linear", 24)] {
        let d = derive(name);
        let (vol, iso) = thin_shell_scene(&d, edge).unwrap();
        let base = RenderOptions { width: 64, height: 64, iso, frames: 1, ..RenderOptions::default() };
        let (_, reference) = cpu_render_with_depth(&d, &vol, &exact(&base));
        let step = RenderOptions { hit: HitMode::Step, step: 0.5, ..base.clone() };
        let (_, stepped) = render_with_depth(gpu, &d, &vol, Layout::Embedded, &step).unwrap();
        let (_, walked) = render_with_depth(gpu, &d, &vol, Layout::Embedded, &exact(&base)).unwrap();
        let (s, x) = (misses(&reference, &stepped), misses(&reference, &walked));
        eprintln!("{name}: step 0.5 {s:?}, exact {x:?}");
        assert!(s.reference_hits > 300, "{name}: the shell is in view ({} pixels)", s.reference_hits);
        assert!(s.missed > 0, "{name}: the shell is thin enough for steps of 0.5 to miss it somewhere");
        assert_eq!(x.missed, 0, "{name}: the exact walk misses no pixel of its reference");
        assert!(x.extra <= 2, "{name}: {} pixels hit where the reference misses", x.extra);
        let dt = max_depth_diff(&reference, &walked);
        assert!(dt < 1e-3, "{name}: depth differs from the reference by {dt}");
    }
}

#[test]
fn exact_walk_matches_its_cpu_reference_on_marschner_lobb_with_and_without_skipping() {
    let gpu = crate::common::gpu();
    for (name, edge, perspective) in [("bcc7", 36, false), ("cc_tricubic", 28, true)] {
        let d = derive(name);
        let vol = LatticeVolume::marschner_lobb(&d.filter.lattice, [edge; 3]).unwrap();
        let o = exact(&RenderOptions { width: 64, height: 64, perspective, frames: 1, ..RenderOptions::default() });
        let (_, reference) = cpu_render_with_depth(&d, &vol, &o);
        for skip in [true, false] {
            let (_, depth) =
                render_with_depth(gpu, &d, &vol, Layout::Embedded, &RenderOptions { skip, ..o.clone() }).unwrap();
            let m = misses(&reference, &depth);
            eprintln!("{name} skip {skip}: {m:?}, depth {}", max_depth_diff(&reference, &depth));
            assert!(m.reference_hits > 500, "{name}: the surface is in view");
            // Hit masks identical except a few silhouette pixels.
            assert!(m.missed + m.extra <= 4, "{name} (skip {skip}): {m:?}");
            let dt = max_depth_diff(&reference, &depth);
            assert!(dt < 1e-3, "{name} (skip {skip}): depth differs from the reference by {dt}");
        }
    }
}

#[test]
fn exact_walk_with_the_distance_map_keeps_every_hit_and_a_wrong_map_loses_some() {
    use boxforge_runtime::render::blocks::SkipMap;
    let gpu = crate::common::gpu();
    let d = derive("cc_tricubic");
    let ml = LatticeVolume::marschner_lobb(&d.filter.lattice, [28; 3]).unwrap();
    let sparse = LatticeVolume::subset(&d.filter.lattice, &crate::common::sparse_balls(48)).unwrap();
    for (what, vol) in [("Marschner-Lobb", &ml), ("sparse", &sparse)] {
        let o = exact(&RenderOptions { width: 64, height: 64, frames: 1, ..RenderOptions::default() });
        let (_, reference) =
            render_with_depth(gpu, &d, vol, Layout::Embedded, &RenderOptions { skip: false, ..o.clone() }).unwrap();
        for map in [SkipMap::Distance, SkipMap::OneBlock, SkipMap::Overshoot] {
            let (_, depth) =
                render_with_depth(gpu, &d, vol, Layout::Embedded, &RenderOptions { skip_map: map, ..o.clone() })
                    .unwrap();
            let m = misses(&reference, &depth);
            let dt = max_depth_diff(&reference, &depth);
            eprintln!("{what} {map:?}: {m:?}, depth {dt}");
            assert!(m.reference_hits > 50, "{what}: the surface is in view");
            let same = m.missed + m.extra == 0 && dt < 1e-3;
            if map == SkipMap::Overshoot {
                // The check below can fail: a map one block too far loses hits.
                assert!(m.missed > 0 && !same, "{what}: a wrong distance map went unnoticed: {m:?}, depth {dt}");
            } else {
                assert!(same, "{what} {map:?}: the skipping changed the hits: {m:?}, depth {dt}");
            }
        }
    }
}
