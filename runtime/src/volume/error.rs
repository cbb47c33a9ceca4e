//! The error type of volume loading and conversion, and the input checks
//! (sample counts, finite values) shared by the loaders and converters.

use std::path::{Path, PathBuf};

/// Everything that can go wrong while loading or converting volumes. Each
/// message names the problem and how to fix it.
#[derive(Debug, thiserror::Error)]
pub enum VolumeError {
    /// The file could not be opened or read.
    #[error("cannot read {path}: {source} (check the path and its permissions)")]
    Io { path: PathBuf, source: std::io::Error },
    /// The NIfTI reader rejected the file (bad magic, header or truncated data).
    #[error(
        "{path} is not a readable NIfTI-1 file: {message} (give a .nii or .nii.gz file, or read it as raw samples with its size and sample type)"
    )]
    Nifti { path: PathBuf, message: String },
    /// The NIfTI file is not a single 3-D volume.
    #[error(
        "{path} holds {rank}-D data with dims {dims:?}: boxforge needs one 3-D scalar volume (extract a single 3-D volume first, e.g. the first time point)"
    )]
    NotThreeD { path: PathBuf, rank: usize, dims: Vec<usize> },
    /// The NIfTI voxel type is not a real scalar (complex, RGB, float128, ...).
    #[error(
        "{path} stores {data_type} voxels: boxforge reads real scalar types only (u8..u64, i8..i64, f32, f64); convert the volume to float32"
    )]
    UnsupportedNiftiType { path: PathBuf, data_type: String },
    /// Some samples are NaN or infinite.
    #[error(
        "{path}: {count} of {total} values are NaN or infinite (first at voxel ({}, {}, {})); boxforge needs finite samples: replace them (e.g. with 0 or the background value) before loading",
        first[0], first[1], first[2]
    )]
    NonFinite { path: PathBuf, count: usize, total: usize, first: [usize; 3] },
    /// A raw file's size does not match its declared dims and type.
    #[error(
        "{path} has {actual} bytes but {}x{}x{} {ty} samples need {expected} bytes: check the dims and sample type (and that the file has no header)",
        dims[0], dims[1], dims[2]
    )]
    RawSize { path: PathBuf, dims: [usize; 3], ty: &'static str, expected: u64, actual: u64 },
    /// Dims with a zero entry, or too large to address.
    #[error("{}{reason}", if dims.iter().all(|&d| d == 0) { String::new() } else { format!("bad volume dims {}x{}x{}: ", dims[0], dims[1], dims[2]) })]
    BadDims { dims: [usize; 3], reason: String },
    /// The data vector does not have `dims[0]*dims[1]*dims[2]` entries.
    #[error("the volume has {len} values but dims {}x{}x{} need {expected}: build it with matching dims and data", dims[0], dims[1], dims[2])]
    DataLength { dims: [usize; 3], len: usize, expected: usize },
    /// Unknown raw sample type.
    #[error("unknown raw sample type '{given}': use u8, u16 (little endian) or f32 (little endian)")]
    BadRawType { given: String },
    /// A malformed NX,NY,NZ,TYPE spec.
    #[error("bad raw volume spec '{spec}': {reason} (expected NX,NY,NZ,TYPE, e.g. 256,256,128,u8)")]
    BadRawSpec { spec: String, reason: String },
    /// The lattice is not 3-D.
    #[error("lattice {lattice} is {dim}-D: lattice volumes are 3-D; use cc, bcc, fcc or a 3-D custom lattice")]
    LatticeDim { lattice: String, dim: usize },
    /// A non-finite or non-positive resampling scale.
    #[error("bad resampling scale {scale}: give a finite scale > 0 (Cartesian voxels per lattice unit)")]
    BadScale { scale: f64 },
    /// The lattice has no coset-packed layout, or the packed grid is too large.
    #[error("no packed layout for lattice {lattice}: {message}")]
    Packed { lattice: String, message: String },
    /// A brick shape or pool that cannot hold the volume.
    #[error("bricked layout: {message}")]
    Bricks { message: String },
    /// A sample format that cannot hold the data.
    #[error("sample format {format}: {message}")]
    Format { format: &'static str, message: String },
    /// A memory-mapped volume file became shorter while it was read (reading
    /// past its new end would crash the process with SIGBUS).
    #[error(
        "the file {path} shrank from {old} to {new} bytes while boxforge read it; do not modify a volume while it is rendered (let the writer finish, then open it again)"
    )]
    Shrunk { path: PathBuf, old: u64, new: u64 },
    /// 4D lattice samples that cannot be built or stored: a box that does
    /// not match its data, a layout a storage buffer cannot take, a buffer
    /// past the adapter's binding limit (the message names the fix).
    #[error("{message}")]
    FourD { message: String },
    /// A time series (4D data) that cannot be read as one: no frames,
    /// frames of different dims, a file of the wrong length or rank.
    #[error("time series: {message}")]
    Series { message: String },
    /// A NaN or infinite sample met while a volume is read box by box.
    #[error(
        "{path}: the sample at voxel ({}, {}, {}) is NaN or infinite; boxforge needs finite samples: replace them (e.g. with 0 or the background value) before loading",
        voxel[0], voxel[1], voxel[2]
    )]
    NonFiniteAt { path: PathBuf, voxel: [usize; 3] },
    /// A .nii.gz file whose gzip stream cannot be decompressed.
    #[error("cannot decompress {path}: {source} (check that the file is a complete .nii.gz, e.g. download it again)")]
    Gzip { path: PathBuf, source: std::io::Error },
    /// The decompressed-volume cache cannot be written.
    #[error(
        "cannot write the decompressed volume cache {path}: {source} (free disk space there or choose another cache directory; it defaults to $XDG_CACHE_HOME/boxforge or ~/.cache/boxforge)"
    )]
    Cache { path: PathBuf, source: std::io::Error },
}

/// The [`VolumeError::Io`] of a file that could not be read.
#[cfg(feature = "files")]
pub(crate) fn io_err(path: &Path) -> impl FnOnce(std::io::Error) -> VolumeError + '_ {
    move |source| VolumeError::Io { path: path.to_path_buf(), source }
}

/// Number of samples of a box, or an error for zero or overflowing dims.
pub(crate) fn checked_count(dims: [usize; 3]) -> Result<usize, VolumeError> {
    if dims.contains(&0) {
        return Err(VolumeError::BadDims { dims, reason: "every dimension must be at least 1".into() });
    }
    dims.iter()
        .try_fold(1usize, |acc, &d| acc.checked_mul(d))
        .filter(|&n| n <= isize::MAX as usize / 8)
        .ok_or_else(|| VolumeError::BadDims { dims, reason: "too many samples to address; use smaller dims".into() })
}

/// Errors with the count and first position of non-finite values.
pub(crate) fn check_finite(path: &Path, dims: [usize; 3], data: &[f32]) -> Result<(), VolumeError> {
    let mut count = 0;
    let mut first = None;
    for (i, v) in data.iter().enumerate() {
        if !v.is_finite() {
            count += 1;
            first.get_or_insert(i);
        }
    }
    match first {
        None => Ok(()),
        Some(i) => Err(VolumeError::NonFinite {
            path: path.to_path_buf(),
            count,
            total: data.len(),
            first: [i % dims[0], (i / dims[0]) % dims[1], i / (dims[0] * dims[1])],
        }),
    }
}
