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
