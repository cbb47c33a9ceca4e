//! What the tests share: one device for the whole binary.

use boxforge_runtime::gpu::Gpu;
use std::sync::OnceLock;

/// The device every GPU test runs on (lavapipe without a GPU), opened once:
/// opening a Vulkan device costs about a second, and tests run in parallel
/// threads on the one device as a host program's renderers would.
pub fn gpu() -> &'static Gpu {
    static GPU: OnceLock<Gpu> = OnceLock::new();
    GPU.get_or_init(|| Gpu::new(None).unwrap_or_else(|e| panic!("{e}")))
}

/// A sparse scene for empty-space skipping: two balls of radius 10 (a cone
/// profile, 1 at the centre, 0.5 on the sphere of radius 5, 0 outside)
/// in an `n`^3 Cartesian volume that is zero elsewhere, so most blocks are
/// empty and many lie several blocks from the nearest occupied one.
pub fn sparse_balls(n: usize) -> boxforge_runtime::volume::Volume {
    let f = n as f64;
    let centres = [[0.3 * f, 0.32 * f, 0.35 * f], [0.7 * f, 0.66 * f, 0.62 * f]];
    let mut data = Vec::with_capacity(n * n * n);
    for z in 0..n {
        for y in 0..n {
            for x in 0..n {
                let p = [x as f64, y as f64, z as f64];
                let v = centres
                    .iter()
                    .map(|c| {
                        let r = ((p[0] - c[0]).powi(2) + (p[1] - c[1]).powi(2) + (p[2] - c[2]).powi(2)).sqrt();
                        (1.0 - r / 10.0).max(0.0)
                    })
                    .fold(0.0, f64::max);
                data.push(v as f32);
            }
        }
    }
    boxforge_runtime::volume::Volume::new([n, n, n], data).unwrap()
}

/// A smooth-plus-ripple test volume (no symmetry a wrong axis order could hide behind).
pub fn ripple_volume(dims: [usize; 3]) -> boxforge_runtime::volume::Volume {
    let mut data = Vec::new();
    for z in 0..dims[2] {
        for y in 0..dims[1] {
            for x in 0..dims[0] {
                let (fx, fy, fz) = (x as f32, y as f32, z as f32);
                data.push(10.0 + fx + 2.0 * fy - 0.5 * fz + 3.0 * (0.9 * fx + 0.4 * fy * fz).sin());
            }
        }
    }
    boxforge_runtime::volume::Volume::new(dims, data).unwrap()
}

/// Every file of a store (its path inside) and its bytes.
pub fn store_files(root: &std::path::Path) -> Vec<(std::path::PathBuf, Vec<u8>)> {
    let mut out = vec![];
    let mut folders = vec![root.to_path_buf()];
    while let Some(dir) = folders.pop() {
        for entry in std::fs::read_dir(&dir).unwrap() {
            let path = entry.unwrap().path();
            if path.is_dir() {
                folders.push(path);
            } else {
                out.push((path.strip_prefix(root).unwrap().to_path_buf(), std::fs::read(&path).unwrap()));
            }
        }
    }
    out.sort();
    out
}
