//! Lattice samples on the device, in the layout the emitted `<f>_fetch` reads.

use crate::gpu::binding::{linear_sampler, sampler_entry, texture_3d_entry};
use crate::gpu::{Gpu, GpuError};
use crate::volume::LatticeVolume;
use boxforge::emit::Layout;
use wgpu::util::DeviceExt;

/// Samples uploaded for one layout, with the bind-group pieces the emitted
/// module declares (embedded: one 3D texture; packed: storage buffer + grid uniform).
pub struct DeviceVolume {
    pub layout: Layout,
    texture_view: Option<wgpu::TextureView>,
    /// With `fetch = linear`: a linear clamp-to-edge sampler at binding + 4
    /// (embedded: the texture bound as filterable; packed: the coset slabs
    /// texture at binding + 5, in `texture_view`).
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
        if layout == Layout::Embedded {
            crate::limits::check_volume_limits(v.dims, v.data.len() as u64 * 4, true, &gpu.limits())
                .map_err(|e| GpuError::Runtime(e.to_string()))?;
        }
        match layout {
            Layout::Embedded => {
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
                let (words, grid) = v.packed().map_err(|e| GpuError::Runtime(e.to_string()))?;
                crate::limits::check_volume_limits(v.dims, words.len() as u64 * 4, false, &gpu.limits())
                    .map_err(|e| GpuError::Runtime(e.to_string()))?;
                let samples = gpu.storage_buffer("packed samples", bytemuck::cast_slice(&words), false);
                let grid = gpu.uniform_buffer("packed grid", bytemuck::cast_slice(&grid));
                Ok(DeviceVolume {
                    layout,
                    texture_view: None,
                    sampler: None,
                    buffers: vec![samples, grid],
                    bytes: words.len() * 4,
                    dims: v.dims,
                    lattice: v.lattice.clone(),
                })
            }
        }
    }

    /// The samples bound for hardware-filtered fetches (modules emitted with
    /// `FetchMode::Linear`): a linear clamp-to-edge sampler at binding + 4
    /// and, embedded, the texture bound as filterable; packed, the buffer and
    /// grid as usual plus the same words as one filterable 3D texture at
    /// binding + 5, the cosets stacked as slabs along z. Needs FLOAT32_FILTERABLE.
    pub fn new_filtered(gpu: &Gpu, v: &LatticeVolume, layout: Layout) -> Result<DeviceVolume, GpuError> {
        if !gpu.device.features().contains(wgpu::Features::FLOAT32_FILTERABLE) {
            return Err(GpuError::Runtime(
                "fetch = linear needs hardware filtering of R32Float textures (FLOAT32_FILTERABLE), which this adapter lacks; use exact fetches".into(),
            ));
        }
        let mut dv = DeviceVolume::new(gpu, v, layout)?;
        dv.sampler = Some(linear_sampler(gpu, "linear samples"));
        if layout == Layout::Packed {
            let (words, grid) = v.packed().map_err(|e| GpuError::Runtime(e.to_string()))?;
            let cosets = words.len() / (grid[3].max(1) as usize);
            let depth = grid[2] as u64 * cosets as u64;
            let max = gpu.limits().max_texture_dimension_3d as u64;
            if grid[0] as u64 > max || grid[1] as u64 > max || depth > max {
                return Err(GpuError::Runtime(format!(
                    "fetch = linear on the packed layout stacks the {cosets} coset grids of {}x{}x{} into one texture {} deep, \
                     over this adapter's max_texture_dimension_3d ({max}); use exact fetches or a smaller volume",
                    grid[0], grid[1], grid[2], depth
                )));
            }
            dv.texture_view =
                Some(r32_texture_3d(gpu, "coset slabs", [grid[0] as u32, grid[1] as u32, depth as u32], &words)?);
            dv.bytes += words.len() * 4;
        }
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
                    wgpu::BindGroupLayoutEntry {
                        binding: first,
                        visibility,
                        ty: wgpu::BindingType::Buffer {
                            ty: wgpu::BufferBindingType::Storage { read_only: true },
                            has_dynamic_offset: false,
                            min_binding_size: None,
                        },
                        count: None,
                    },
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
                    e.push(texture_3d_entry(first + 5, visibility, true));
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
                    wgpu::BindGroupEntry { binding: first, resource: self.buffers[0].as_entire_binding() },
                    wgpu::BindGroupEntry { binding: first + 1, resource: self.buffers[1].as_entire_binding() },
                ];
                if let (Some(s), Some(view)) = (&self.sampler, &self.texture_view) {
                    e.push(wgpu::BindGroupEntry { binding: first + 4, resource: wgpu::BindingResource::Sampler(s) });
                    e.push(wgpu::BindGroupEntry {
                        binding: first + 5,
                        resource: wgpu::BindingResource::TextureView(view),
                    });
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
