//! The emitted prefilter kernel on the device equals the CPU convolution,
//! for every 3D catalog filter and both layouts.

use boxforge::derive::Derivation;
use boxforge::emit::Layout;
use boxforge_runtime::prefilter::{prefilter_cpu, prefilter_gpu};
use boxforge_runtime::volume::LatticeVolume;

#[test]
fn gpu_prefilter_equals_cpu_for_every_3d_filter_and_layout() {
    let gpu = crate::common::gpu();
    for name in boxforge::spec::catalog::names() {
        let d = Derivation::new(&boxforge::spec::catalog::get(name).unwrap()).unwrap();
        if d.facts.dim != 3 {
            continue;
        }
        let vol = LatticeVolume::marschner_lobb(&d.filter.lattice, [20, 20, 20]).unwrap();
        let cpu = prefilter_cpu(&d, &vol);
        for layout in [Layout::Embedded, Layout::Packed] {
            let g = prefilter_gpu(gpu, &d, &vol, layout).unwrap();
            // Compare away from the border (the layouts clamp differently there).
            let r = boxforge_runtime::verify::support_radius(&d) as i64 + 2;
            let mut max: f32 = 0.0;
            for z in r..20 - r {
                for y in r..20 - r {
                    for x in r..20 - r {
                        let i = (x + 20 * (y + 20 * z)) as usize;
                        max = max.max((g.data[i] - cpu.data[i]).abs());
                    }
                }
            }
            assert!(max < 1e-5, "{name} {layout:?}: {max}");
            if d.prefilter.taps.len() > 1 {
                assert!(cpu.data != vol.data, "{name}: a non-trivial prefilter changes the data");
            }
        }
    }
}

/// Out of core: the prefilter in z-slabs of a source, written to a raw f32
/// file and read back through a memory map, equals the CPU prefilter of the
/// whole volume (slabs forced small, so halos meet in the volume's interior).
#[test]
fn the_prefilter_in_slabs_to_a_file_equals_the_whole_volume_prefilter() {
    let gpu = crate::common::gpu();
    for name in ["bcc7", "cc_tricubic", "fcc6"] {
        let d = boxforge::derive::Derivation::new(&boxforge::spec::catalog::get(name).unwrap()).unwrap();
        let vol = boxforge_runtime::volume::LatticeVolume::marschner_lobb(&d.filter.lattice, [18, 14, 23]).unwrap();
        let path = std::env::temp_dir().join(format!("boxforge-prefilter-{name}-{}.raw", std::process::id()));
        let slabs = std::cell::Cell::new(0);
        boxforge_runtime::prefilter::prefilter_to_file(gpu, &d, &vol, &path, 3000, &|_, n| slabs.set(n)).unwrap();
        let back = boxforge_runtime::volume::MappedVolume::open_raw(
            &path,
            vol.dims,
            boxforge_runtime::volume::RawType::F32,
            &d.filter.lattice,
        )
        .unwrap();
        let cpu = boxforge_runtime::prefilter::prefilter_cpu(&d, &vol);
        let mut got = vec![0f32; cpu.data.len()];
        use boxforge_runtime::volume::BrickSource;
        back.read_box([0, 0, 0], vol.dims, &mut got).unwrap();
        let _ = std::fs::remove_file(&path);
        let err = cpu.data.iter().zip(&got).map(|(a, b)| (a - b).abs()).fold(0.0f32, f32::max);
        assert!(slabs.get() >= 3, "{name}: {} slabs; the test needs several", slabs.get());
        assert!(err < 1e-5, "{name}: slab prefilter differs by {err}");
    }
}
