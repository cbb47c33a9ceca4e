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
}
