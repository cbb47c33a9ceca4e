//! Lattice samples on the device, in the layout the emitted `<f>_fetch` reads.

use crate::gpu::binding::{linear_sampler, sampler_entry, texture_3d_entry};
use crate::gpu::{Gpu, GpuError};
use crate::volume::LatticeVolume;
use boxforge::emit::Layout;
use wgpu::util::DeviceExt;

/// Samples uploaded for one layout, with the bind-group pieces the emitted
/// module declares (embedded: one 3D texture; packed: one 3D texture with a
/// tile per coset + the coset grid uniform).
pub struct DeviceVolume {
    pub layout: Layout,
    texture_view: Option<wgpu::TextureView>,
    /// With `fetch = linear`: a linear clamp-to-edge sampler at binding + 4
    /// (the texture bound as filterable, in either layout).
    sampler: Option<wgpu::Sampler>,
    buffers: Vec<wgpu::Buffer>,
    /// Bytes on the device for the samples.
    pub bytes: usize,
    /// Lattice samples per axis of the volume (what the ray casters bound their rays by).
    pub dims: [usize; 3],
    /// The samples' lattice (a renderer written for one lattice checks it).
    pub lattice: boxforge::spec::lattice::Lattice,
}

impl DeviceVolume {
    pub fn new(gpu: &Gpu, v: &LatticeVolume, layout: Layout) -> Result<DeviceVolume, GpuError> {
        match layout {
            Layout::Embedded => {
                crate::limits::check_volume_limits(v.dims, v.dims, layout, &gpu.limits())
                    .map_err(|e| GpuError::Runtime(e.to_string()))?;
                let [nx, ny, nz] = v.dims;
                let view = r32_texture_3d(gpu, "embedded samples", [nx as u32, ny as u32, nz as u32], &v.data)?;
                Ok(DeviceVolume {
                    layout,
                    texture_view: Some(view),
                    sampler: None,
                    buffers: vec![],
                    bytes: v.data.len() * 4,
                    dims: v.dims,
                    lattice: v.lattice.clone(),
                })
            }
            Layout::Packed => {
                let p = v.packed().map_err(|e| GpuError::Runtime(e.to_string()))?;
                crate::limits::check_volume_limits(v.dims, p.texture, layout, &gpu.limits())
                    .map_err(|e| GpuError::Runtime(e.to_string()))?;
                let [tx, ty, tz] = p.texture;
                let view = r32_texture_3d(gpu, "packed samples", [tx as u32, ty as u32, tz as u32], &p.words)?;
                let grid = gpu.uniform_buffer("packed grid", bytemuck::cast_slice(&p.grid));
                Ok(DeviceVolume {
                    layout,
                    texture_view: Some(view),
                    sampler: None,
                    buffers: vec![grid],
                    bytes: p.words.len() * 4,
                    dims: v.dims,
                    lattice: v.lattice.clone(),
                })
            }
        }
    }

    /// The samples bound for hardware-filtered fetches (modules emitted with
    /// `FetchMode::Linear`): the same texture as [`DeviceVolume::new`], bound
    /// as filterable, and a linear clamp-to-edge sampler at binding + 4 (no
    /// extra memory). Needs FLOAT32_FILTERABLE.
    pub fn new_filtered(gpu: &Gpu, v: &LatticeVolume, layout: Layout) -> Result<DeviceVolume, GpuError> {
        if !gpu.device.features().contains(wgpu::Features::FLOAT32_FILTERABLE) {
            return Err(GpuError::Runtime(
                "fetch = linear needs hardware filtering of R32Float textures (FLOAT32_FILTERABLE), which this adapter lacks; use exact fetches".into(),
            ));
        }
        let mut dv = DeviceVolume::new(gpu, v, layout)?;
        dv.sampler = Some(linear_sampler(gpu, "linear samples"));
        Ok(dv)
    }

    /// Whether the samples are bound for hardware filtering.
    pub fn filtered(&self) -> bool {
        self.sampler.is_some()
    }

    /// Layout entries starting at `first` (binding numbers used by the emitter).
    pub fn layout_entries(&self, first: u32, visibility: wgpu::ShaderStages) -> Vec<wgpu::BindGroupLayoutEntry> {
        match self.layout {
            Layout::Embedded => {
                let mut e = vec![texture_3d_entry(first, visibility, self.filtered())];
                if self.filtered() {
                    e.push(sampler_entry(first + 4, visibility));
                }
                e
            }
            Layout::Packed => {
                let mut e = vec![
                    texture_3d_entry(first, visibility, self.filtered()),
                    wgpu::BindGroupLayoutEntry {
                        binding: first + 1,
                        visibility,
                        ty: wgpu::BindingType::Buffer {
                            ty: wgpu::BufferBindingType::Uniform,
                            has_dynamic_offset: false,
                            min_binding_size: None,
                        },
                        count: None,
                    },
                ];
                if self.filtered() {
                    e.push(sampler_entry(first + 4, visibility));
                }
                e
            }
        }
    }

    /// Bind-group entries matching [`DeviceVolume::layout_entries`].
    pub fn bind_entries(&self, first: u32) -> Vec<wgpu::BindGroupEntry<'_>> {
        match self.layout {
            Layout::Embedded => {
                let mut e = vec![wgpu::BindGroupEntry {
                    binding: first,
                    resource: wgpu::BindingResource::TextureView(self.texture_view.as_ref().unwrap()),
                }];
                if let Some(s) = &self.sampler {
                    e.push(wgpu::BindGroupEntry { binding: first + 4, resource: wgpu::BindingResource::Sampler(s) });
                }
                e
            }
            Layout::Packed => {
                let mut e = vec![
                    wgpu::BindGroupEntry {
                        binding: first,
                        resource: wgpu::BindingResource::TextureView(self.texture_view.as_ref().unwrap()),
                    },
                    wgpu::BindGroupEntry { binding: first + 1, resource: self.buffers[0].as_entire_binding() },
                ];
                if let Some(s) = &self.sampler {
                    e.push(wgpu::BindGroupEntry { binding: first + 4, resource: wgpu::BindingResource::Sampler(s) });
                }
                e
            }
        }
    }
}

/// An R32Float 3D texture of `size` texels filled with `data` (x fastest).
fn r32_texture_3d(gpu: &Gpu, label: &str, size: [u32; 3], data: &[f32]) -> Result<wgpu::TextureView, GpuError> {
    let tex = gpu.checked(&format!("upload {label}"), || {
        gpu.device.create_texture_with_data(
            &gpu.queue,
            &wgpu::TextureDescriptor {
                label: Some(label),
                size: wgpu::Extent3d { width: size[0], height: size[1], depth_or_array_layers: size[2] },
                mip_level_count: 1,
                sample_count: 1,
                dimension: wgpu::TextureDimension::D3,
                format: wgpu::TextureFormat::R32Float,
                usage: wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST,
                view_formats: &[],
            },
            wgpu::util::TextureDataOrder::LayerMajor,
            bytemuck::cast_slice(data),
        )
    })?;
    Ok(tex.create_view(&wgpu::TextureViewDescriptor::default()))
}
