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
    /// Projected tetrahedra tile only the BCC and CC lattices.
    #[error("projected tetrahedra need BCC or CC data, not the {lattice} lattice: use the ray caster")]
    PtLattice { lattice: String },
    /// Projected tetrahedra in a perspective view.
    #[error("projected tetrahedra here are orthographic (the implicit back-to-front traversal is a visibility order only for parallel projection): render a parallel view or use the ray caster")]
    PtPerspective,
    /// Projected tetrahedra's samples or visible tetrahedra past one storage binding.
    #[error("projected tetrahedra: the {what} take {bytes} bytes, over this adapter's storage-binding limit of {limit}: use a smaller volume (e.g. resampled from a downsampled file) or the ray caster")]
    PtTooLarge { what: &'static str, bytes: u64, limit: u64 },
    /// A hand-written BCC scheme given samples on another lattice.
    #[error("{scheme} reads BCC samples; the volume is on the {lattice} lattice")]
    SchemeLattice { scheme: &'static str, lattice: String },
    /// A hand-written scheme given samples in a layout its loads do not read.
    #[error("{scheme} reads the embedded layout (one 3D texture of the samples); upload the volume in that layout")]
    SchemeLayout { scheme: &'static str },
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

impl RenderError {
    /// The error as a [`GpuError`], for the one-shot functions that return
    /// one: a device error as it is, a refused target as its message.
    pub(crate) fn into_gpu(self) -> GpuError {
        match self {
            RenderError::Gpu(e) => e,
            other => GpuError::Runtime(other.to_string()),
        }
    }
}
