//! What can stop a benchmark.

use crate::gpu::GpuError;
use crate::verify::VerifyError;
use crate::volume::VolumeError;

/// Why a benchmark (or one of its sections) could not run. The messages are
/// the library's; the CLI names its own flags where an input came from one.
#[derive(Debug, thiserror::Error)]
pub enum BenchError {
    #[error(transparent)]
    Gpu(#[from] GpuError),
    #[error(transparent)]
    Verify(#[from] VerifyError),
    #[error(transparent)]
    Volume(#[from] VolumeError),
    /// A filter name that does not resolve, or a filter that does not derive.
    #[error("{0}")]
    Derive(String),
    /// The generator refused a module.
    #[error("{0}")]
    Emit(String),
    #[error("the MNI head {path} is missing: run from the repository root (it ships data/), or leave it out")]
    MissingMni { path: String },
    /// The external shader to time against a generated module.
    #[error("cannot read {path}: {reason} (check the path)")]
    ExternalShader { path: String, reason: String },
}

impl BenchError {
    /// [`BenchError::Derive`] from any error's message.
    pub(crate) fn derive(e: impl std::fmt::Display) -> BenchError {
        BenchError::Derive(e.to_string())
    }

    /// [`BenchError::Emit`] from any error's message.
    pub(crate) fn emit(e: impl std::fmt::Display) -> BenchError {
        BenchError::Emit(e.to_string())
    }
}
