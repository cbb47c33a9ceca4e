//! Bind group layout entries and samplers: the small pieces every pipeline
//! of the runtime assembles its layouts from.

use crate::gpu::Gpu;

/// A 3D float texture binding (filterable for hardware linear fetches).
pub fn texture_3d_entry(binding: u32, visibility: wgpu::ShaderStages, filterable: bool) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility,
        ty: wgpu::BindingType::Texture {
            sample_type: wgpu::TextureSampleType::Float { filterable },
            view_dimension: wgpu::TextureViewDimension::D3,
            multisampled: false,
        },
        count: None,
    }
}

/// The binding of a sample texture whose texels are `texels` (a sample
/// format's [`texels`](crate::volume::SampleFormat::texels)): `texture_3d<f32>`
/// (filterable when `filterable`), or `texture_3d<u32>` for u8 words.
pub fn samples_texture_entry(
    binding: u32,
    visibility: wgpu::ShaderStages,
    texels: boxforge::emit::Texels,
    filterable: bool,
) -> wgpu::BindGroupLayoutEntry {
    match texels {
        boxforge::emit::Texels::Float => texture_3d_entry(binding, visibility, filterable),
        boxforge::emit::Texels::U8x4 => uint_texture_3d_entry(binding, visibility),
    }
}

/// A `texture_3d<u32>` binding (read with textureLoad): page tables, u8 words.
pub fn uint_texture_3d_entry(binding: u32, visibility: wgpu::ShaderStages) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility,
        ty: wgpu::BindingType::Texture {
            sample_type: wgpu::TextureSampleType::Uint,
            view_dimension: wgpu::TextureViewDimension::D3,
            multisampled: false,
        },
        count: None,
    }
}

/// A filtering sampler binding.
pub fn sampler_entry(binding: u32, visibility: wgpu::ShaderStages) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility,
        ty: wgpu::BindingType::Sampler(wgpu::SamplerBindingType::Filtering),
        count: None,
    }
}

/// A linear-filtering, clamp-to-edge sampler (hardware trilinear fetches).
pub fn linear_sampler(gpu: &Gpu, label: &str) -> wgpu::Sampler {
    gpu.device.create_sampler(&wgpu::SamplerDescriptor {
        label: Some(label),
        address_mode_u: wgpu::AddressMode::ClampToEdge,
        address_mode_v: wgpu::AddressMode::ClampToEdge,
        address_mode_w: wgpu::AddressMode::ClampToEdge,
        mag_filter: wgpu::FilterMode::Linear,
        min_filter: wgpu::FilterMode::Linear,
        ..Default::default()
    })
}

/// A storage-buffer layout entry.
pub fn storage_entry(binding: u32, read_only: bool) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::COMPUTE,
        ty: wgpu::BindingType::Buffer {
            ty: wgpu::BufferBindingType::Storage { read_only },
            has_dynamic_offset: false,
            min_binding_size: None,
        },
        count: None,
    }
}

/// A uniform-buffer layout entry.
pub fn uniform_entry(binding: u32) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::COMPUTE,
        ty: wgpu::BindingType::Buffer {
            ty: wgpu::BufferBindingType::Uniform,
            has_dynamic_offset: false,
            min_binding_size: None,
        },
        count: None,
    }
}

/// A compute-stage `texture_3d<u32>` binding (read with textureLoad).
pub fn texture_entry(binding: u32) -> wgpu::BindGroupLayoutEntry {
    uint_texture_3d_entry(binding, wgpu::ShaderStages::COMPUTE)
}

/// A compute-stage `texture_depth_2d` binding (a host's depth buffer, read
/// with textureLoad).
pub fn depth_texture_entry(binding: u32) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::COMPUTE,
        ty: wgpu::BindingType::Texture {
            sample_type: wgpu::TextureSampleType::Depth,
            view_dimension: wgpu::TextureViewDimension::D2,
            multisampled: false,
        },
        count: None,
    }
}

/// A compute-stage `texture_storage_3d<r32uint, write>` binding.
pub fn storage_texture_entry(binding: u32) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::COMPUTE,
        ty: wgpu::BindingType::StorageTexture {
            access: wgpu::StorageTextureAccess::WriteOnly,
            format: wgpu::TextureFormat::R32Uint,
            view_dimension: wgpu::TextureViewDimension::D3,
        },
        count: None,
    }
}

/// The layout entries of bind group `group` as the shader declares them:
/// `bindings` is the shader's table (`boxforge::validate::bindings_of_wgsl`,
/// the same table each report lists), so binding numbers and kinds come from
/// the shader rather than from numbers written again here. Sampled textures
/// and samplers are left to their owners (the samples' group is laid out by
/// [`crate::volume::DeviceVolume`], which knows whether they are filterable).
pub fn layout_entries_from(
    bindings: &[boxforge::validate::Binding],
    group: u32,
) -> Result<Vec<wgpu::BindGroupLayoutEntry>, crate::gpu::GpuError> {
    bindings
        .iter()
        .filter(|b| b.group == group)
        .map(|b| match b.kind.as_str() {
            "storage buffer read" => Ok(storage_entry(b.binding, true)),
            "storage buffer read_write" => Ok(storage_entry(b.binding, false)),
            "uniform buffer" => Ok(uniform_entry(b.binding)),
            "texture_depth_2d" => Ok(depth_texture_entry(b.binding)),
            other => Err(crate::gpu::GpuError::UnsupportedBinding {
                group,
                binding: b.binding,
                name: b.name.clone(),
                kind: other.to_string(),
            }),
        })
        .collect()
}

/// The bind group entries among `resources` (binding, buffer) that the
/// shader declares in `group` (a template leaves out what a mode does not use).
pub fn entries_for<'a>(
    bindings: &[boxforge::validate::Binding],
    group: u32,
    resources: &[(u32, &'a wgpu::Buffer)],
) -> Vec<wgpu::BindGroupEntry<'a>> {
    resources
        .iter()
        .filter(|(binding, _)| bindings.iter().any(|b| b.group == group && b.binding == *binding))
        .map(|&(binding, buffer)| wgpu::BindGroupEntry { binding, resource: buffer.as_entire_binding() })
        .collect()
}
