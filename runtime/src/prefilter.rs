//! Quasi-interpolation prefilter on the device with the emitted
//! `<f>_prefilter_main` kernel, and the same convolution on the CPU.

use crate::gpu::binding::storage_entry;
use crate::gpu::{Gpu, GpuError};
use crate::volume::LatticeVolume;
use crate::volume::{DeviceVolume, VolumeOptions};
use boxforge::derive::Derivation;
use boxforge::emit::{emit, Layout};

/// Why the device prefilter could not run.
#[derive(Debug, thiserror::Error)]
pub enum PrefilterError {
    #[error(transparent)]
    Gpu(#[from] GpuError),
    /// The generator refused the module (its message names the reason).
    #[error(transparent)]
    Emit(#[from] boxforge::Error),
    /// The source volume could not be read.
    #[error(transparent)]
    Volume(#[from] crate::volume::VolumeError),
    /// The prefiltered file could not be written.
    #[error("cannot write {path}: {source} (check that its folder exists and is writable)")]
    Write { path: std::path::PathBuf, source: std::io::Error },
    #[error(
        "volume of {points} points is too large for one prefilter dispatch on this device; split it or use a smaller volume"
    )]
    TooLarge { points: usize },
}

/// c_j = sum_k q_k f(j - k) at every lattice point of the box (clamped
/// fetches at the border, like the shaders), on the CPU.
pub fn prefilter_cpu(d: &Derivation, vol: &LatticeVolume) -> LatticeVolume {
    let [nx, ny, nz] = vol.dims;
    let taps: Vec<(Vec<i64>, f64)> = d.prefilter.taps.iter().map(|(k, w)| (k.clone(), w.to_f64())).collect();
    let mut out = vol.clone();
    for z in 0..nz {
        for y in 0..ny {
            for x in 0..nx {
                let j = [x as i64, y as i64, z as i64];
                let i = x + nx * (y + ny * z);
                out.data[i] = if vol.is_lattice(&j) {
                    taps.iter().map(|(k, w)| w * vol.get(&[j[0] - k[0], j[1] - k[1], j[2] - k[2]]) as f64).sum::<f64>()
                        as f32
                } else {
                    0.0
                };
            }
        }
    }
    out
}

/// The same with the emitted kernel on the device.
pub fn prefilter_gpu(
    gpu: &Gpu,
    d: &Derivation,
    vol: &LatticeVolume,
    layout: Layout,
) -> Result<LatticeVolume, PrefilterError> {
    prefilter_gpu_with(gpu, d, vol, layout, &VolumeOptions::default())
}

/// [`prefilter_gpu`] with the samples stored as `options` says (a compact
/// format or bricks): the kernel reads them in that format and writes f32
/// values (the sample map applied to each sum).
pub fn prefilter_gpu_with(
    gpu: &Gpu,
    d: &Derivation,
    vol: &LatticeVolume,
    layout: Layout,
    options: &VolumeOptions,
) -> Result<LatticeVolume, PrefilterError> {
    let name = &d.filter.name;
    let dv = DeviceVolume::with_options(gpu, vol, layout, options)?;
    dv.check_filter(d)?;
    let module = emit(d, &dv.emit_options("boxforge prefilter"))?;
    let shader = gpu.compile(&module.file_name, &module.source)?;
    let dev = &gpu.device;
    let out_binding = layout.sample_bindings();
    let mut entries = dv.layout_entries(0, wgpu::ShaderStages::COMPUTE);
    entries.push(storage_entry(out_binding, false));
    entries.push(gpu.params_entry(out_binding + 1));
    let bgl =
        dev.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor { label: Some("prefilter"), entries: &entries });
    let n = vol.data.len();
    let out = gpu.storage_buffer("prefiltered", &vec![0u8; n * 4], true);
    let [nx, ny, nz] = vol.dims;
    let job: [i32; 8] = [0, 0, 0, 0, nx as i32, ny as i32, nz as i32, 1];
    let job_buf = gpu.uniform_buffer("job", bytemuck::cast_slice(&job));
    let mut bind = dv.bind_entries(0);
    bind.push(wgpu::BindGroupEntry { binding: out_binding, resource: out.as_entire_binding() });
    bind.push(wgpu::BindGroupEntry { binding: out_binding + 1, resource: job_buf.as_entire_binding() });
    let bg =
        dev.create_bind_group(&wgpu::BindGroupDescriptor { label: Some("prefilter"), layout: &bgl, entries: &bind });
    let pipeline = gpu.pipeline("prefilter", &shader, &[&bgl], &format!("{name}_prefilter_main"))?;
    let groups = (n as u32).div_ceil(64);
    if groups > gpu.device.limits().max_compute_workgroups_per_dimension {
        return Err(PrefilterError::TooLarge { points: n });
    }
    gpu.dispatch("prefilter", &pipeline, &[&bg], (groups, 1, 1))?;
    let data: Vec<f32> = bytemuck::cast_slice(&gpu.read_buffer(&out)?).to_vec();
    Ok(LatticeVolume { lattice: vol.lattice.clone(), dims: vol.dims, data })
}

/// The prefilter out of core: `source` read and prefiltered in z-slabs of
/// whole xy planes, each with a halo as wide as the taps reach (rounded up
/// to the lattice's period, so local coordinates keep the lattice), by the
/// emitted `<f>_prefilter_main` on an embedded sub-volume; the results are
/// written to `out` as raw little-endian f32 (x fastest, 0 off the lattice),
/// the layout a [`crate::volume::MappedVolume`] reads back. Host and device
/// memory stay about `max_texels` texels whatever the volume's size.
pub fn prefilter_to_file(
    gpu: &Gpu,
    d: &Derivation,
    source: &dyn crate::volume::BrickSource,
    out: &std::path::Path,
    max_texels: usize,
    progress: &dyn Fn(usize, usize),
) -> Result<(), PrefilterError> {
    use std::io::Write;
    let name = &d.filter.name;
    let dims = source.dims();
    let period = crate::render::paged::bounds::lattice_period(source.lattice());
    let reach =
        d.prefilter.taps.iter().flat_map(|(k, _)| k.iter().map(|c| c.unsigned_abs() as usize)).max().unwrap_or(0);
    let halo = reach.div_ceil(period).max(1) * period;
    let plane = (dims[0] + 2 * halo) * (dims[1] + 2 * halo);
    // z-planes per slab: a multiple of the period, the texels and the
    // points of one dispatch capped.
    let by_texels = (max_texels / plane).saturating_sub(2 * halo);
    let by_points = (65535 * 64) / (dims[0] * dims[1]).max(1);
    let nz = (by_texels.min(by_points) / period * period).max(period).min(dims[2].next_multiple_of(period));
    let module =
        emit(d, &boxforge::emit::EmitOptions { command: "boxforge prefilter (slabs)".into(), ..Default::default() })?;
    let shader = gpu.compile(&module.file_name, &module.source)?;
    let dev = &gpu.device;
    let entries = [
        crate::gpu::binding::texture_3d_entry(0, wgpu::ShaderStages::COMPUTE, false),
        storage_entry(1, false),
        gpu.params_entry(2),
    ];
    let bgl = dev.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
        label: Some("prefilter slab"),
        entries: &entries,
    });
    let pipeline = gpu.pipeline("prefilter slab", &shader, &[&bgl], &format!("{name}_prefilter_main"))?;
    let size = [dims[0] + 2 * halo, dims[1] + 2 * halo, nz + 2 * halo];
    let tex = gpu.sampled_texture_3d("prefilter slab", size.map(|n| n as u32), wgpu::TextureFormat::R32Float);
    let view = tex.create_view(&Default::default());
    let outbuf = gpu.storage_buffer("prefiltered slab", &vec![0u8; dims[0] * dims[1] * nz * 4], true);
    let job_buf = gpu.uniform_buffer("prefilter job", &[0u8; 32]);
    let bg = dev.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("prefilter slab"),
        layout: &bgl,
        entries: &[
            wgpu::BindGroupEntry { binding: 0, resource: wgpu::BindingResource::TextureView(&view) },
            wgpu::BindGroupEntry { binding: 1, resource: outbuf.as_entire_binding() },
            wgpu::BindGroupEntry { binding: 2, resource: job_buf.as_entire_binding() },
        ],
    });
    let io = |e: std::io::Error| PrefilterError::Write { path: out.to_path_buf(), source: e };
    let tmp = out.with_extension("partial");
    let mut file = std::io::BufWriter::new(std::fs::File::create(&tmp).map_err(io)?);
    let mut values = vec![0f32; size[0] * size[1] * size[2]];
    let slabs = dims[2].div_ceil(nz);
    for (i, z0) in (0..dims[2]).step_by(nz).enumerate() {
        let n = nz.min(dims[2] - z0);
        let lo = [-(halo as i64), -(halo as i64), z0 as i64 - halo as i64];
        let box_size = [size[0], size[1], n + 2 * halo];
        let texels = box_size[0] * box_size[1] * box_size[2];
        source.read_box(lo, box_size, &mut values[..texels])?;
        gpu.queue.write_texture(
            wgpu::TexelCopyTextureInfo {
                texture: &tex,
                mip_level: 0,
                origin: wgpu::Origin3d::ZERO,
                aspect: wgpu::TextureAspect::All,
            },
            bytemuck::cast_slice(&values[..texels]),
            wgpu::TexelCopyBufferLayout {
                offset: 0,
                bytes_per_row: Some(box_size[0] as u32 * 4),
                rows_per_image: Some(box_size[1] as u32),
            },
            wgpu::Extent3d {
                width: box_size[0] as u32,
                height: box_size[1] as u32,
                depth_or_array_layers: box_size[2] as u32,
            },
        );
        let h = halo as i32;
        let job: [i32; 8] = [h, h, h, 0, dims[0] as i32, dims[1] as i32, n as i32, 1];
        gpu.queue.write_buffer(&job_buf, 0, bytemuck::cast_slice(&job));
        let points = dims[0] * dims[1] * n;
        gpu.dispatch("prefilter slab", &pipeline, &[&bg], ((points as u32).div_ceil(64), 1, 1))?;
        let bytes = gpu.read_buffer(&outbuf)?;
        file.write_all(&bytes[..points * 4]).map_err(io)?;
        progress(i + 1, slabs);
    }
    file.flush().map_err(io)?;
    drop(file);
    std::fs::rename(&tmp, out).map_err(io)?;
    Ok(())
}
