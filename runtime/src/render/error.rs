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
