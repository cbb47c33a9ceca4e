//! The renderers' error type.

use crate::gpu::GpuError;

/// What can go wrong building or driving a renderer.
#[derive(Debug, thiserror::Error)]
pub enum RenderError {
    #[error(transparent)]
    Gpu(#[from] GpuError),
    #[error("the target has no pixels: give it a width and height of at least 1")]
    EmptyTarget,
    #[error("a {width}x{height} image needs {} bytes in one storage binding, over this device's max_storage_buffer_binding_size ({limit}); render a smaller target", *width as u64 * *height as u64 * 4)]
    TargetTooLarge { width: u32, height: u32, limit: u64 },
    /// A host depth texture ([`crate::render::camera::HostDepth`]) of a format the ray casters cannot read as depth.
    #[error("the host depth texture is {format:?}, which the ray casters do not read: pass a Depth32Float, Depth24Plus or Depth16Unorm texture (no stencil aspect)")]
    HostDepthFormat { format: wgpu::TextureFormat },
    /// A host depth texture the ray casters cannot bind.
    #[error(
        "the host depth texture has usage {usage:?} without TEXTURE_BINDING: create it with TEXTURE_BINDING as well"
    )]
    HostDepthUsage { usage: wgpu::TextureUsages },
    /// A host depth texture whose texels are not the target's pixels.
    #[error("the host depth texture is {}x{} with {samples} sample(s), the target {}x{}: pass a single-sample depth texture of the target's size", depth[0], depth[1], target[0], target[1])]
    HostDepthSize { depth: [u32; 2], samples: u32, target: [u32; 2] },
}
