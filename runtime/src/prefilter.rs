//! Quasi-interpolation prefilter on the device with the emitted
//! `<f>_prefilter_main` kernel, and the same convolution on the CPU.

use crate::gpu::binding::{storage_entry, uniform_entry};
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
    #[error("{0}")]
    Emit(String),
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
    let module = emit(d, &dv.emit_options("boxforge prefilter")).map_err(|e| PrefilterError::Emit(e.to_string()))?;
    let shader = gpu.compile(&module.file_name, &module.source)?;
    let dev = &gpu.device;
    let out_binding = layout.sample_bindings();
    let mut entries = dv.layout_entries(0, wgpu::ShaderStages::COMPUTE);
    entries.push(storage_entry(out_binding, false));
    entries.push(uniform_entry(out_binding + 1));
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
