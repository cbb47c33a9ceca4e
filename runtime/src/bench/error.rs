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
    #[error(transparent)]
    Render(#[from] crate::render::RenderError),
    /// A filter name that does not resolve, a filter that does not derive,
    /// or a module the generator refused (its message names the reason).
    #[error(transparent)]
    Generator(#[from] boxforge::Error),
    /// A translation into another shading language that failed.
    #[error(transparent)]
    Translate(#[from] boxforge::back::BackError),
    /// A translated program that could not be compiled or run.
    #[error(transparent)]
    Target(#[from] crate::targets::TargetError),
    #[error("the MNI head {path} is missing: run from the repository root (it ships data/), or leave it out")]
    MissingMni { path: String },
    /// A kernel that filters in hardware (it declares the `ref_linear`
    /// sampler) given samples in a layout the sampler cannot read.
    #[error("{label} filters the samples in hardware, which needs the embedded layout (one 3D texture of the samples), not the {} layout: upload the volume in the embedded layout", layout.name())]
    FilterLayout { label: String, layout: boxforge::emit::Layout },
    /// The external shader to time against a generated module.
    #[error("cannot read {path}: {reason} (check the path)")]
    ExternalShader { path: String, reason: String },
}
