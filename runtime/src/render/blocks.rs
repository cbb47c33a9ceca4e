//! The min/max block grid every ray caster skips empty space with: [min,
//! max] of the spline over blocks of unit cubes, from the emitted
//! `<f>_minmax_main` kernel (the BB coefficients' hull), computed once per
//! volume and uploaded for the ray casters.

use crate::gpu::binding::{storage_entry, uniform_entry};
use crate::gpu::{Gpu, GpuError};
use crate::volume::DeviceVolume;
use boxforge::emit::Layout;

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
    let out_binding = if dv.layout == Layout::Packed { 2 } else { 1 };
    let mut entries0 = dv.layout_entries(0, wgpu::ShaderStages::COMPUTE);
    entries0.push(storage_entry(out_binding, false));
    entries0.push(uniform_entry(out_binding + 1));
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
