//! The min/max block grid every ray caster skips empty space with: [min,
//! max] of the spline over blocks of unit cubes, from the emitted
//! `<f>_minmax_main` kernel (the BB coefficients' hull), computed once per
//! volume and uploaded for the ray casters.

use crate::gpu::binding::storage_entry;
use crate::gpu::{Gpu, GpuError};
use crate::volume::DeviceVolume;

/// Blocks per axis of a grid of `block`^3 cubes over a volume of `dims` samples.
pub fn blocks_per_axis(dims: [usize; 3], block: i32) -> [i32; 3] {
    dims.map(|n| (n as i32 + block - 1) / block)
}

/// The bounds as a read-only storage buffer of `vec2<f32>` (the ray casters' `_blocks`).
pub fn upload(gpu: &Gpu, label: &str, bounds: &[[f32; 2]]) -> wgpu::Buffer {
    gpu.storage_buffer(label, bytemuck::cast_slice(bounds), false)
}

/// [min, max] of the spline over each block of `block`^3 unit cubes of the
/// volume (x fastest) with the emitted `<f>_minmax_main` of `shader`,
/// dispatched in z-slabs of blocks so that no dispatch exceeds 65535
/// workgroups (block 1, one bound per cell, on a large volume).
pub fn block_bounds(
    gpu: &Gpu,
    shader: &wgpu::ShaderModule,
    name: &str,
    dv: &DeviceVolume,
    dims: [usize; 3],
    block: i32,
) -> Result<Vec<[f32; 2]>, GpuError> {
    let dev = &gpu.device;
    let blocks = blocks_per_axis(dims, block);
    let slab = (blocks[0] * blocks[1]) as usize;
    let nblocks = slab * blocks[2] as usize;
    let out_binding = dv.layout.sample_bindings();
    let mut entries0 = dv.layout_entries(0, wgpu::ShaderStages::COMPUTE);
    entries0.push(storage_entry(out_binding, false));
    entries0.push(gpu.params_entry(out_binding + 1));
    let bgl_mm =
        dev.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor { label: Some("minmax"), entries: &entries0 });
    let minmax = gpu.pipeline("minmax", shader, &[&bgl_mm], &format!("{name}_minmax_main"))?;
    let slabs_per_dispatch = ((65535 * 64) / slab.max(1)).max(1) as i32;
    let mut bounds = Vec::with_capacity(nblocks);
    let mut z0 = 0;
    while z0 < blocks[2] {
        let nz = slabs_per_dispatch.min(blocks[2] - z0);
        let count = slab * nz as usize;
        let blocks_buf = gpu.storage_buffer("blocks", &vec![0u8; count * 8], true);
        let job: [i32; 8] = [0, 0, z0 * block, 0, blocks[0], blocks[1], nz, block];
        let job_buf = gpu.uniform_buffer("job", bytemuck::cast_slice(&job));
        let mut bind0 = dv.bind_entries(0);
        bind0.push(wgpu::BindGroupEntry { binding: out_binding, resource: blocks_buf.as_entire_binding() });
        bind0.push(wgpu::BindGroupEntry { binding: out_binding + 1, resource: job_buf.as_entire_binding() });
        let bg_mm = dev.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("minmax"),
            layout: &bgl_mm,
            entries: &bind0,
        });
        gpu.dispatch("minmax", &minmax, &[&bg_mm], ((count as u32).div_ceil(64), 1, 1))?;
        let raw: Vec<f32> = bytemuck::cast_slice(&gpu.read_buffer(&blocks_buf)?).to_vec();
        bounds.extend(raw.chunks(2).map(|b| [b[0], b[1]]));
        z0 += nz;
    }
    Ok(bounds)
}

/// Which skipping map the ray casters read (with skipping on).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum SkipMap {
    /// Per block, the Chebyshev distance (in blocks, capped at
    /// [`MAX_SKIP_DISTANCE`]) to the nearest occupied block: a ray jumps
    /// over the whole box of blocks that are certainly empty around it.
    #[default]
    Distance,
    /// One empty block (or fine cube) at a time, as before the distance map.
    OneBlock,
    /// For tests only: every nonzero distance one block too large, a wrong
    /// map (rays jump past surface) that the skipping tests must catch.
    Overshoot,
}

impl SkipMap {
    /// The map a ray caster reads: `distances` as they are, clamped to one
    /// block, or (testing) overshooting by one.
    pub fn apply(self, mut distances: Vec<u32>) -> Vec<u32> {
        match self {
            SkipMap::Distance => {}
            SkipMap::OneBlock => distances.iter_mut().for_each(|d| *d = (*d).min(1)),
            SkipMap::Overshoot => distances.iter_mut().filter(|d| **d > 0).for_each(|d| *d += 1),
        }
        distances
    }
}

/// The cap of the distance map (the maps are exact below it, and a capped
/// entry only jumps less far than it could).
pub const MAX_SKIP_DISTANCE: u32 = 255;

/// How long building a skipping map took and what it holds.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct SkipMapStats {
    /// CPU time of the distance transform, in ms.
    pub build_ms: f64,
    /// Bytes of the map on the device.
    pub bytes: usize,
    /// Mean skip distance over the empty blocks (1: one block at a time).
    pub mean_distance: f64,
}

/// The Chebyshev (chessboard) distance transform of the block grid:
/// for each block (x fastest, `blocks` per axis), the distance in blocks to
/// the nearest block with `empty` 0, i.e. the largest d such that every
/// block within Chebyshev distance d - 1 (clamped at the grid's faces) is
/// empty; 0 for an occupied block, capped at [`MAX_SKIP_DISTANCE`] (also
/// where nothing is occupied). Exact by two raster passes of the 26-neighbour
/// chamfer mask with unit weights (the chessboard metric is the path metric
/// of that graph, and the grid is convex).
pub fn chebyshev_distances(empty: &[u32], blocks: [i32; 3]) -> Vec<u32> {
    let [nx, ny, nz] = blocks.map(|n| n.max(0) as usize);
    assert_eq!(empty.len(), nx * ny * nz, "one flag per block");
    let far = MAX_SKIP_DISTANCE;
    let mut d: Vec<u32> = empty.iter().map(|&e| if e != 0 { far } else { 0 }).collect();
    let idx = |x: usize, y: usize, z: usize| (z * ny + y) * nx + x;
    // The 13 neighbours before a block in raster order (x fastest).
    let mut back = Vec::new();
    for dz in -1i64..=1 {
        for dy in -1i64..=1 {
            for dx in -1i64..=1 {
                if (dz, dy, dx) < (0, 0, 0) {
                    back.push([dx, dy, dz]);
                }
            }
        }
    }
    let pass = |d: &mut Vec<u32>, x: usize, y: usize, z: usize, sign: i64| {
        let i = idx(x, y, z);
        if d[i] == 0 {
            return;
        }
        let mut best = d[i];
        for o in &back {
            let (qx, qy, qz) = (x as i64 + sign * o[0], y as i64 + sign * o[1], z as i64 + sign * o[2]);
            if qx < 0 || qy < 0 || qz < 0 || qx >= nx as i64 || qy >= ny as i64 || qz >= nz as i64 {
                continue;
            }
            best = best.min(d[idx(qx as usize, qy as usize, qz as usize)] + 1);
        }
        d[i] = best;
    };
    for z in 0..nz {
        for y in 0..ny {
            for x in 0..nx {
                pass(&mut d, x, y, z, 1);
            }
        }
    }
    for z in (0..nz).rev() {
        for y in (0..ny).rev() {
            for x in (0..nx).rev() {
                pass(&mut d, x, y, z, -1);
            }
        }
    }
    d
}

/// [`chebyshev_distances`] of `empty` less `offset` (at least 0), through
/// `map`, timed; the stats' `bytes` are 4 per block.
pub fn skip_map(empty: &[u32], blocks: [i32; 3], offset: u32, map: SkipMap) -> (Vec<u32>, SkipMapStats) {
    let start = std::time::Instant::now();
    let d = chebyshev_distances(empty, blocks).into_iter().map(|d| d.saturating_sub(offset)).collect();
    let d = map.apply(d);
    let build_ms = start.elapsed().as_secs_f64() * 1e3;
    let (sum, n) = d.iter().filter(|&&v| v > 0).fold((0u64, 0u64), |(s, n), &v| (s + v as u64, n + 1));
    let mean_distance = if n == 0 { 0.0 } else { sum as f64 / n as f64 };
    let bytes = 4 * d.len();
    (d, SkipMapStats { build_ms, bytes, mean_distance })
}

/// The bounds followed by the iso ray caster's distance map (two distances,
/// as exact small floats, per `vec2`): the `_blocks` buffer of
/// templates/raycast.wgsl.j2 in skipping mode 2.
pub fn bounds_with_distances(bounds: &[[f32; 2]], distances: &[u32]) -> Vec<[f32; 2]> {
    let mut out = bounds.to_vec();
    out.extend(distances.chunks(2).map(|c| [c[0] as f32, c.get(1).copied().unwrap_or(0) as f32]));
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The distance by definition: the nearest occupied block in the max norm.
    fn brute(empty: &[u32], b: [i32; 3]) -> Vec<u32> {
        let n = b[0] * b[1] * b[2];
        let at = |i: i32| [i % b[0], (i / b[0]) % b[1], i / (b[0] * b[1])];
        (0..n)
            .map(|i| {
                let p = at(i);
                (0..n)
                    .filter(|&j| empty[j as usize] == 0)
                    .map(|j| {
                        let q = at(j);
                        (0..3).map(|a| (p[a] - q[a]).unsigned_abs()).max().unwrap()
                    })
                    .min()
                    .unwrap_or(MAX_SKIP_DISTANCE)
                    .min(MAX_SKIP_DISTANCE)
            })
            .collect()
    }

    #[test]
    fn chebyshev_distances_match_the_definition() {
        let b = [9, 7, 6];
        let n = (b[0] * b[1] * b[2]) as usize;
        for (seed, density) in [(1u64, 3u64), (7, 17), (13, 97), (5, 1000)] {
            let mut s = seed;
            let empty: Vec<u32> = (0..n)
                .map(|_| {
                    s = s.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
                    ((s >> 33) % density != 0) as u32
                })
                .collect();
            assert_eq!(chebyshev_distances(&empty, b), brute(&empty, b), "seed {seed}");
        }
        assert_eq!(chebyshev_distances(&[1; 8], [2, 2, 2]), vec![MAX_SKIP_DISTANCE; 8]);
        assert_eq!(chebyshev_distances(&[1, 1, 0, 1, 1, 1, 1], [7, 1, 1]), [2, 1, 0, 1, 2, 3, 4]);
    }

    #[test]
    fn the_map_modes() {
        let d = vec![0, 1, 3];
        assert_eq!(SkipMap::Distance.apply(d.clone()), [0, 1, 3]);
        assert_eq!(SkipMap::OneBlock.apply(d.clone()), [0, 1, 1]);
        assert_eq!(SkipMap::Overshoot.apply(d), [0, 2, 4]);
        assert_eq!(
            bounds_with_distances(&[[0.0, 1.0]; 3], &[4, 5, 6]),
            [[0.0, 1.0], [0.0, 1.0], [0.0, 1.0], [4.0, 5.0], [6.0, 0.0]]
        );
    }
}
