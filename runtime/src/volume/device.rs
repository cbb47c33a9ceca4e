//! Lattice samples on the device, in the layout the emitted `<f>_fetch` reads.

use crate::gpu::binding::{linear_sampler, sampler_entry, samples_texture_entry, uint_texture_3d_entry};
use crate::gpu::{Gpu, GpuError};
use crate::volume::{BrickShape, LatticeVolume, SampleFormat, VolumeError};
use boxforge::emit::{Layout, SampleMap};
use wgpu::util::DeviceExt;

/// How a [`DeviceVolume`] stores its samples beyond the layout: the sample
/// format and, for the bricked layout, the brick shape.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct VolumeOptions {
    /// Stored sample format (f32 by default).
    pub format: SampleFormat,
    /// Brick edge and halo (bricked layout only).
    pub bricks: BrickShape,
    /// Largest pool texture edge for the bricked layout (None: the adapter's
    /// 3D texture limit); tests force small pools with it.
    pub max_pool_edge: Option<usize>,
}

impl Default for VolumeOptions {
    fn default() -> Self {
        VolumeOptions {
            format: SampleFormat::F32,
            bricks: BrickShape { edge: BrickShape::DEFAULT_EDGE, halo: DEFAULT_HALO },
            max_pool_edge: None,
        }
    }
}

/// The halo [`DeviceVolume::new`] gives bricks when no filter is named: wide
/// enough for every built-in filter (a test holds it to their
/// [`boxforge::emit::bricks::brick_halo`]); renderers check a volume's halo
/// against their filter's and say how to rebuild it.
pub const DEFAULT_HALO: usize = 5;

/// Samples uploaded for one layout, with the bind-group pieces the emitted
/// module declares (embedded: one 3D texture; packed: one 3D texture with a
/// tile per coset + the coset grid uniform; bricked: the pool texture, the
/// bricks uniform and the page table).
pub struct DeviceVolume {
    pub layout: Layout,
    texture_view: Option<wgpu::TextureView>,
    /// The page table (bricked layout).
    pages_view: Option<wgpu::TextureView>,
    /// With `fetch = linear`: a linear clamp-to-edge sampler at binding + 4
    /// (the texture bound as filterable, in either layout).
    sampler: Option<wgpu::Sampler>,
    buffers: Vec<wgpu::Buffer>,
    /// Bytes on the device for the samples (with the page table and halos).
    pub bytes: usize,
    /// Lattice samples per axis of the volume (what the ray casters bound their rays by).
    pub dims: [usize; 3],
    /// The samples' lattice (a renderer written for one lattice checks it).
    pub lattice: boxforge::spec::lattice::Lattice,
    /// Stored sample format.
    pub format: SampleFormat,
    /// Stored sample to value: the module emitted for this volume applies it.
    pub map: SampleMap,
    /// The brick shape (bricked layout).
    pub bricks: Option<BrickShape>,
}

impl DeviceVolume {
    /// f32 samples in `layout` (bricks of the default shape).
    pub fn new(gpu: &Gpu, v: &LatticeVolume, layout: Layout) -> Result<DeviceVolume, VolumeError> {
        DeviceVolume::with_options(gpu, v, layout, &VolumeOptions::default())
    }

    /// Samples in `layout`, stored as `options` says.
    pub fn with_options(
        gpu: &Gpu,
        v: &LatticeVolume,
        layout: Layout,
        options: &VolumeOptions,
    ) -> Result<DeviceVolume, VolumeError> {
        let format = options.format;
        if format == SampleFormat::U16 && !gpu.device.features().contains(wgpu::Features::TEXTURE_FORMAT_16BIT_NORM) {
            return Err(GpuError::MissingFeature {
                feature: "TEXTURE_FORMAT_16BIT_NORM",
                needed_for: "u16 samples (R16Unorm textures)".into(),
                fix: "store the samples as f16, u8 or f32",
            }
            .into());
        }
        // Only the normalized formats need the range (a pass over every sample).
        let map = match format {
            SampleFormat::U8 | SampleFormat::U16 => {
                let (lo, hi) = v.sample_range();
                format.map_for(lo, hi)
            }
            SampleFormat::F32 | SampleFormat::F16 => SampleMap::IDENTITY,
        };
        let mut dv = DeviceVolume {
            layout,
            texture_view: None,
            pages_view: None,
            sampler: None,
            buffers: vec![],
            bytes: 0,
            dims: v.dims,
            lattice: v.lattice.clone(),
            format,
            map,
            bricks: None,
        };
        match layout {
            Layout::Embedded => {
                crate::limits::check_volume_limits(v.dims, v.dims, layout, &gpu.limits())?;
                let bytes = format.encode_rows(&v.data, map, v.dims[0])?;
                let size = format.texture_size(v.dims);
                dv.texture_view = Some(texture_3d(gpu, "embedded samples", size, format.texture_format(), &bytes)?);
                dv.bytes = bytes.len();
            }
            Layout::Packed => {
                let p = v.packed()?;
                crate::limits::check_volume_limits(v.dims, p.texture, layout, &gpu.limits())?;
                let bytes = format.encode_rows(&p.words, map, p.texture[0])?;
                let size = format.texture_size(p.texture);
                dv.texture_view = Some(texture_3d(gpu, "packed samples", size, format.texture_format(), &bytes)?);
                dv.buffers.push(gpu.uniform_buffer("packed grid", bytemuck::cast_slice(&p.grid)));
                dv.bytes = bytes.len();
            }
            Layout::Bricked | Layout::BrickedPacked => {
                let max = options.max_pool_edge.unwrap_or(gpu.limits().max_texture_dimension_3d as usize);
                let b = if layout == Layout::Bricked {
                    v.bricked(options.bricks, max)
                } else {
                    // Coset-packed slots need an even halo (and edge).
                    let shape = BrickShape { halo: options.bricks.halo.next_multiple_of(2), ..options.bricks };
                    v.bricked_packed(shape, max)
                }?;
                let bytes = format.encode_rows(&b.pool, map, b.pool_size()[0])?;
                let size = format.texture_size(b.pool_size());
                dv.texture_view = Some(texture_3d(gpu, "brick pool", size, format.texture_format(), &bytes)?);
                let pages = b.bricks.map(|n| n as u32);
                dv.pages_view = Some(texture_3d(
                    gpu,
                    "page table",
                    pages,
                    wgpu::TextureFormat::R32Uint,
                    bytemuck::cast_slice(&b.pages),
                )?);
                dv.buffers.push(gpu.uniform_buffer("bricks", bytemuck::cast_slice(&b.uniform)));
                dv.bytes = bytes.len() + b.pages.len() * 4;
                dv.bricks = Some(b.shape);
            }
        }
        Ok(dv)
    }

    /// The samples bound for hardware-filtered fetches (modules emitted with
    /// `FetchMode::Linear`): the same texture as [`DeviceVolume::new`], bound
    /// as filterable, and a linear clamp-to-edge sampler at binding + 4 (no
    /// extra memory). Needs FLOAT32_FILTERABLE.
    pub fn new_filtered(gpu: &Gpu, v: &LatticeVolume, layout: Layout) -> Result<DeviceVolume, VolumeError> {
        if !gpu.device.features().contains(wgpu::Features::FLOAT32_FILTERABLE) {
            return Err(GpuError::MissingFeature {
                feature: "FLOAT32_FILTERABLE",
                needed_for: "linear fetches (hardware filtering of R32Float textures)".into(),
                fix: "use exact fetches",
            }
            .into());
        }
        if layout.is_bricked() {
            return Err(VolumeError::LinearBricked);
        }
        let mut dv = DeviceVolume::new(gpu, v, layout)?;
        dv.sampler = Some(linear_sampler(gpu, "linear samples"));
        Ok(dv)
    }

    /// Whether the samples are bound for hardware filtering.
    pub fn filtered(&self) -> bool {
        self.sampler.is_some()
    }

    /// The emitter's options for a module that reads this volume: its layout
    /// and sample map (the rest default).
    pub fn emit_options(&self, command: &str) -> boxforge::emit::EmitOptions {
        boxforge::emit::EmitOptions {
            layout: self.layout,
            samples: self.map,
            texels: self.format.texels(),
            command: command.into(),
            ..Default::default()
        }
    }

    /// Refuses a bricked volume whose halo is narrower than filter `d`'s
    /// stencils reach (its fetches would leave the slot).
    pub fn check_filter(&self, d: &boxforge::derive::Derivation) -> Result<(), VolumeError> {
        if let Some(b) = self.bricks {
            let need = boxforge::emit::bricks::brick_halo(d);
            if b.halo < need {
                return Err(VolumeError::HaloTooNarrow { halo: b.halo, filter: d.filter.name.clone(), need });
            }
        }
        Ok(())
    }

    /// Layout entries starting at `first` (binding numbers used by the emitter).
    pub fn layout_entries(&self, first: u32, visibility: wgpu::ShaderStages) -> Vec<wgpu::BindGroupLayoutEntry> {
        let uniform = |binding: u32| wgpu::BindGroupLayoutEntry {
            binding,
            visibility,
            ty: wgpu::BindingType::Buffer {
                ty: wgpu::BufferBindingType::Uniform,
                has_dynamic_offset: false,
                min_binding_size: None,
            },
            count: None,
        };
        let mut e = vec![samples_texture_entry(first, visibility, self.format.texels(), self.filtered())];
        match self.layout {
            Layout::Embedded => {}
            Layout::Packed => e.push(uniform(first + 1)),
            Layout::Bricked | Layout::BrickedPacked => {
                e.push(uniform(first + 1));
                e.push(uint_texture_3d_entry(first + 2, visibility));
            }
        }
        if self.filtered() {
            e.push(sampler_entry(first + 4, visibility));
        }
        e
    }

    /// Bind-group entries matching [`DeviceVolume::layout_entries`].
    pub fn bind_entries(&self, first: u32) -> Vec<wgpu::BindGroupEntry<'_>> {
        let view = self.texture_view.as_ref().expect("every layout uploads a texture");
        let mut e = vec![wgpu::BindGroupEntry { binding: first, resource: wgpu::BindingResource::TextureView(view) }];
        match self.layout {
            Layout::Embedded => {}
            Layout::Packed => {
                e.push(wgpu::BindGroupEntry { binding: first + 1, resource: self.buffers[0].as_entire_binding() })
            }
            Layout::Bricked | Layout::BrickedPacked => {
                e.push(wgpu::BindGroupEntry { binding: first + 1, resource: self.buffers[0].as_entire_binding() });
                let pages = self.pages_view.as_ref().expect("the bricked layout uploads its page table");
                e.push(wgpu::BindGroupEntry {
                    binding: first + 2,
                    resource: wgpu::BindingResource::TextureView(pages),
                });
            }
        }
        if let Some(s) = &self.sampler {
            e.push(wgpu::BindGroupEntry { binding: first + 4, resource: wgpu::BindingResource::Sampler(s) });
        }
        e
    }
}

/// A 3D texture of `format` and `size` texels filled with `bytes` (x fastest).
fn texture_3d(
    gpu: &Gpu,
    label: &str,
    size: [u32; 3],
    format: wgpu::TextureFormat,
    bytes: &[u8],
) -> Result<wgpu::TextureView, GpuError> {
    let tex = gpu.checked(&format!("upload {label}"), || {
        gpu.device.create_texture_with_data(
            &gpu.queue,
            &wgpu::TextureDescriptor {
                label: Some(label),
                size: wgpu::Extent3d { width: size[0], height: size[1], depth_or_array_layers: size[2] },
                mip_level_count: 1,
                sample_count: 1,
                dimension: wgpu::TextureDimension::D3,
                format,
                usage: wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST,
                view_formats: &[],
            },
            wgpu::util::TextureDataOrder::LayerMajor,
            bytes,
        )
    })?;
    Ok(tex.create_view(&wgpu::TextureViewDescriptor::default()))
}

#[cfg(test)]
mod tests {
    use super::DEFAULT_HALO;

    #[test]
    fn the_default_halo_covers_every_builtin_filter() {
        for name in boxforge::spec::catalog::names() {
            let d = boxforge::derive::Derivation::new(&boxforge::spec::catalog::get(name).unwrap()).unwrap();
            if d.facts.dim == 3 {
                let h = boxforge::emit::bricks::brick_halo(&d);
                assert!(h <= DEFAULT_HALO, "{name} needs a halo of {h}, over DEFAULT_HALO {DEFAULT_HALO}");
            }
        }
    }
}
