//! Bricked preprocessing: the min/max block grid of a volume computed a row
//! of bricks at a time, so that it works on volumes that never fit on the
//! device. Each row of bricks is read from the source with a halo as wide
//! as the stencils reach (rounded up to the lattice's period, so local
//! coordinates keep the lattice), stored in the sample format the renderer
//! will use, uploaded as an embedded sub-volume, and bounded by the emitted
//! `<f>_minmax_main` kernel over the row's blocks: the same kernel over the
//! same samples as in core, so the bounds are the in-core bounds.

use crate::gpu::binding::{samples_texture_entry, storage_entry};
use crate::gpu::Gpu;
use crate::render::RenderError;
use crate::volume::{BrickSource, SampleFormat};
use boxforge::derive::Derivation;
use boxforge::emit::{emit, EmitOptions, Layout, SampleMap};

/// The smallest p with p Z^3 inside the lattice (p <= |det|): offsets that
/// are multiples of p keep lattice points on lattice points.
pub fn lattice_period(lattice: &boxforge::spec::lattice::Lattice) -> usize {
    let det = lattice.det().unsigned_abs().max(1) as usize;
    (1..=det)
        .find(|&p| {
            (0..3).all(|a| lattice.contains(&std::array::from_fn::<i64, 3, _>(|b| if a == b { p as i64 } else { 0 })))
        })
        .unwrap_or(det)
}

/// Bounds [min, max] (value units, the map applied) of every block of
/// `block`^3 cubes over the source (x fastest), computed brick row by brick
/// row. `brick` must be a multiple of `block` and of the lattice period;
/// `max_texels` caps the sub-volume a row is uploaded as.
#[allow(clippy::too_many_arguments)]
pub fn brick_row_bounds(
    gpu: &Gpu,
    d: &Derivation,
    source: &dyn BrickSource,
    format: SampleFormat,
    map: SampleMap,
    brick: usize,
    block: usize,
    max_texels: usize,
    progress: &dyn Fn(usize, usize),
) -> Result<Vec<[f32; 2]>, RenderError> {
    let name = &d.filter.name;
    let dims = source.dims();
    let period = lattice_period(source.lattice());
    let reach = boxforge::emit::bricks::brick_halo(d);
    let halo = reach.div_ceil(period) * period;
    let module = emit(
        d,
        &EmitOptions {
            layout: Layout::Embedded,
            samples: map,
            texels: format.texels(),
            command: "boxforge render (bricked bounds)".into(),
            ..Default::default()
        },
    )?;
    let shader = gpu.compile(&module.file_name, &module.source)?;
    let dev = &gpu.device;
    let entries = [
        samples_texture_entry(0, wgpu::ShaderStages::COMPUTE, format.texels(), false),
        storage_entry(1, false),
        gpu.params_entry(2),
    ];
    let bgl =
        dev.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor { label: Some("row bounds"), entries: &entries });
    let pipeline = gpu.pipeline("row bounds", &shader, &[&bgl], &format!("{name}_minmax_main"))?;

    let bricks = dims.map(|n| n.div_ceil(brick));
    let blocks = dims.map(|n| n.div_ceil(block));
    let per_brick = brick / block;
    let side = brick + 2 * halo;
    // A slab: up to a texture edge of bricks along x and as many rows along
    // y and layers along z as `max_texels` device texels (and one dispatch's
    // workgroups) allow. The host fills it one row of bricks at a time (its
    // memory: one row), the device bounds it in one dispatch (lavapipe keeps
    // about a megabyte per dispatch of a large kernel, so few dispatches).
    let max_edge = gpu.limits().max_texture_dimension_3d as usize;
    let fit = |avail: usize, cap: usize| ((avail.saturating_sub(2 * halo)) / brick).clamp(1, cap);
    let row_len = fit(max_edge, bricks[0]);
    let width = row_len * brick + 2 * halo;
    let rows_y = fit((max_texels / (width * side)).min(max_edge), bricks[1]);
    let height = rows_y * brick + 2 * halo;
    let max_blocks = 65535 * 64;
    let layers_z = fit((max_texels / (width * height)).min(max_edge), bricks[2])
        .min((max_blocks / (row_len * rows_y * per_brick.pow(3))).max(1));
    let depth = layers_z * brick + 2 * halo;
    let mut bounds = vec![[0f32; 2]; blocks[0] * blocks[1] * blocks[2]];
    // One texture, output and job buffer for every slab (a smaller last slab
    // uses a corner of them: its stencils never reach past what it writes).
    let tex =
        gpu.sampled_texture_3d("brick slab", format.texture_size([width, height, depth]), format.texture_format());
    let view = tex.create_view(&Default::default());
    let out = gpu.storage_buffer("slab bounds", &vec![0u8; row_len * rows_y * layers_z * per_brick.pow(3) * 8], true);
    let job_buf = gpu.uniform_buffer("slab job", &[0u8; 32]);
    let bg = dev.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("slab bounds"),
        layout: &bgl,
        entries: &[
            wgpu::BindGroupEntry { binding: 0, resource: wgpu::BindingResource::TextureView(&view) },
            wgpu::BindGroupEntry { binding: 1, resource: out.as_entire_binding() },
            wgpu::BindGroupEntry { binding: 2, resource: job_buf.as_entire_binding() },
        ],
    });
    let rows = bricks[0].div_ceil(row_len) * bricks[1] * bricks[2];
    let mut done = 0;
    let mut values = Vec::new();
    for kz0 in (0..bricks[2]).step_by(layers_z) {
        for ky0 in (0..bricks[1]).step_by(rows_y) {
            for kx0 in (0..bricks[0]).step_by(row_len) {
                let n = [row_len.min(bricks[0] - kx0), rows_y.min(bricks[1] - ky0), layers_z.min(bricks[2] - kz0)];
                // Row by row: the box of one row of bricks with its halo
                // (neighbouring rows' halos overlap with the same texels).
                for kz in kz0..kz0 + n[2] {
                    for ky in ky0..ky0 + n[1] {
                        let size = [n[0] * brick + 2 * halo, side, side];
                        let lo = [
                            (kx0 * brick) as i64 - halo as i64,
                            (ky * brick) as i64 - halo as i64,
                            (kz * brick) as i64 - halo as i64,
                        ];
                        values.resize(size[0] * size[1] * size[2], 0.0);
                        source.read_box(lo, size, &mut values)?;
                        // The samples the renderer will read, in its texture
                        // format (the device's conversion of stored texels is the same).
                        let stored = format.encode_rows(&values, map, size[0])?;
                        gpu.queue.write_texture(
                            wgpu::TexelCopyTextureInfo {
                                texture: &tex,
                                mip_level: 0,
                                origin: wgpu::Origin3d {
                                    x: 0,
                                    y: ((ky - ky0) * brick) as u32,
                                    z: ((kz - kz0) * brick) as u32,
                                },
                                aspect: wgpu::TextureAspect::All,
                            },
                            &stored,
                            wgpu::TexelCopyBufferLayout {
                                offset: 0,
                                bytes_per_row: Some(format.row_bytes(size[0]) as u32),
                                rows_per_image: Some(size[1] as u32),
                            },
                            wgpu::Extent3d {
                                width: format.texture_size(size)[0],
                                height: size[1] as u32,
                                depth_or_array_layers: size[2] as u32,
                            },
                        );
                        // Flush the staging copy now, so host memory holds one row.
                        gpu.queue.submit([]);
                        done += 1;
                        progress(done, rows);
                    }
                    gpu.wait()?;
                }
                let count = [n[0] * per_brick, n[1] * per_brick, n[2] * per_brick];
                let total = count[0] * count[1] * count[2];
                let h = halo as i32;
                let job: [i32; 8] = [h, h, h, 0, count[0] as i32, count[1] as i32, count[2] as i32, block as i32];
                gpu.queue.write_buffer(&job_buf, 0, bytemuck::cast_slice(&job));
                gpu.dispatch("slab bounds", &pipeline, &[&bg], ((total as u32).div_ceil(64), 1, 1))?;
                crate::memory::trace_memory("slab bounded");
                let raw: Vec<f32> = bytemuck::cast_slice(&gpu.read_buffer(&out)?[..total * 8]).to_vec();
                for bz in 0..count[2] {
                    for by in 0..count[1] {
                        for bx in 0..count[0] {
                            let g = [kx0 * per_brick + bx, ky0 * per_brick + by, kz0 * per_brick + bz];
                            if g[0] < blocks[0] && g[1] < blocks[1] && g[2] < blocks[2] {
                                let i = bx + count[0] * (by + count[1] * bz);
                                bounds[g[0] + blocks[0] * (g[1] + blocks[1] * g[2])] = [raw[2 * i], raw[2 * i + 1]];
                            }
                        }
                    }
                }
            }
        }
    }
    // Free the slab now: the pool is allocated next, within the same budget.
    tex.destroy();
    out.destroy();
    gpu.wait()?;
    Ok(bounds)
}

/// The block bounds of one source, filter and storage kept in a file
/// (`<dir>/bounds-<FNV-1a of the key>.bin`): a header line with the whole
/// key (so a hash collision reads as a miss), the block count, then (min,
/// max) as little-endian f32 pairs. Written atomically.
pub struct BoundsCache {
    path: std::path::PathBuf,
    key: String,
}

const BOUNDS_MAGIC: &str = "boxforge block bounds 1";

impl BoundsCache {
    /// The cache entry for `key` in `dir`.
    pub fn new(dir: &std::path::Path, key: String) -> BoundsCache {
        let mut h: u64 = 0xcbf2_9ce4_8422_2325;
        for b in key.bytes() {
            h = (h ^ u64::from(b)).wrapping_mul(0x0100_0000_01b3);
        }
        BoundsCache { path: dir.join(format!("bounds-{h:016x}.bin")), key }
    }

    /// The file it reads and writes.
    pub fn path(&self) -> &std::path::Path {
        &self.path
    }

    /// The cached bounds, when the file exists, holds this key and exactly
    /// `blocks` finite pairs; None otherwise (a miss: compute them).
    pub fn read(&self, blocks: usize) -> Option<Vec<[f32; 2]>> {
        let bytes = std::fs::read(&self.path).ok()?;
        let header = format!("{BOUNDS_MAGIC}\n{}\n{blocks}\n", self.key);
        let body = bytes.strip_prefix(header.as_bytes())?;
        if body.len() != blocks * 8 {
            return None;
        }
        let pairs: Vec<[f32; 2]> = body
            .chunks_exact(8)
            .map(|c| {
                let f = |i: usize| f32::from_le_bytes([c[i], c[i + 1], c[i + 2], c[i + 3]]);
                [f(0), f(4)]
            })
            .collect();
        pairs.iter().all(|p| p[0].is_finite() && p[1].is_finite() && p[0] <= p[1]).then_some(pairs)
    }

    /// Keeps `bounds` for the next render (creating the folder).
    pub fn write(&self, bounds: &[[f32; 2]]) -> std::io::Result<()> {
        if let Some(dir) = self.path.parent() {
            std::fs::create_dir_all(dir)?;
        }
        let mut bytes = format!("{BOUNDS_MAGIC}\n{}\n{}\n", self.key, bounds.len()).into_bytes();
        for b in bounds {
            bytes.extend_from_slice(&b[0].to_le_bytes());
            bytes.extend_from_slice(&b[1].to_le_bytes());
        }
        boxforge::build::output::write_atomic(&self.path, &bytes).map_err(|e| std::io::Error::other(e.to_string()))
    }
}

#[cfg(test)]
mod cache_tests {
    use super::*;

    #[test]
    fn bounds_round_trip_and_other_keys_or_counts_miss() {
        let dir = std::env::temp_dir().join(format!("boxforge-bounds-cache-{}", std::process::id()));
        let c = BoundsCache::new(&dir, "a file|bcc7|f32".into());
        assert!(c.read(3).is_none(), "nothing cached yet");
        let b = vec![[0.0, 1.0], [-2.5, 3.0], [0.25, 0.25]];
        c.write(&b).unwrap();
        assert_eq!(c.read(3), Some(b));
        assert!(c.read(4).is_none(), "another block count is a miss");
        assert!(BoundsCache::new(&dir, "a file|fcc6|f32".into()).read(3).is_none(), "another key is a miss");
        let _ = std::fs::remove_dir_all(&dir);
    }
}
