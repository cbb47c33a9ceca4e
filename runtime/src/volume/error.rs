//! The error type of volume loading and conversion, and the input checks
//! (sample counts, finite values) shared by the loaders and converters.

use std::path::{Path, PathBuf};

/// Everything that can go wrong while loading or converting volumes. Each
/// message names the problem and how to fix it.
#[derive(Debug, thiserror::Error)]
pub enum VolumeError {
    /// The device failed while the samples were uploaded, or lacks a
    /// feature the requested storage needs.
    #[error(transparent)]
    Gpu(#[from] crate::gpu::GpuError),
    /// The volume is past one of the device's limits (the message names it).
    #[error(transparent)]
    Limit(#[from] crate::limits::LimitError),
    /// An OME-Zarr store that cannot be read or written (boxed: its
    /// variants carry whole shapes and scales).
    #[cfg(feature = "zarr")]
    #[error(transparent)]
    Zarr(Box<super::zarr::ZarrError>),
    /// Hardware-filtered (linear) fetches asked of a bricked volume.
    #[error("linear fetches are not offered on the bricked layouts: use exact fetches or the packed layout")]
    LinearBricked,
    /// Bricks whose halo is narrower than the filter's stencils reach.
    #[error("the volume's bricks have a halo of {halo} texels but filter {filter} reaches {need}: build the volume with BrickShape::for_filter")]
    HaloTooNarrow { halo: usize, filter: String, need: usize },
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
    /// A brick edge or halo of 0.
    #[error("bricked layout: brick edge {edge} and halo {halo}: both must be at least 1 (e.g. an edge of 32)")]
    BrickShape { edge: usize, halo: usize },
    /// The bricked-packed layout with an odd brick edge or halo.
    #[error("bricked layout: the bricked-packed layout needs an even brick edge and halo (got {edge} and {halo}); e.g. an edge of 32")]
    BrickParity { edge: usize, halo: usize },
    /// More bricks than a pool texture of the device's edge holds.
    #[error("bricked layout: {bricks} bricks of {slot}^3 texels (halo included) do not fit in a pool texture of {max_edge} per edge; use a larger brick edge or a smaller volume")]
    PoolFull { bricks: usize, slot: usize, max_edge: usize },
    /// A pool past i32 texel indexing.
    #[error("bricked layout: a pool of {texels} texels is too large; use fewer or smaller bricks")]
    PoolTooLarge { texels: u128 },
    /// A sample format that cannot hold the data.
    #[error("sample format {format}: {message}")]
    Format { format: &'static str, message: String },
    /// A memory-mapped volume file became shorter while it was read (reading
    /// past its new end would crash the process with SIGBUS).
    #[error(
        "the file {path} shrank from {old} to {new} bytes while boxforge read it; do not modify a volume while it is rendered (let the writer finish, then open it again)"
    )]
    Shrunk { path: PathBuf, old: u64, new: u64 },
    /// A 4D box with no points, or past i32 indexing.
    #[error("a 4D box of {dims:?} points is empty or past i32 indexing: use a smaller box")]
    FourDBox { dims: [usize; 4] },
    /// 4D data whose length does not match its box.
    #[error("{len} values for a 4D box of {dims:?} need {expected}: build it with matching dims and data")]
    FourDLength { dims: [usize; 4], len: usize, expected: usize },
    /// 4D samples past the adapter's storage-binding limit.
    #[error("the 4D samples need {} MiB in the {layout} layout, over this adapter's storage binding limit of {} MiB: use fewer frames or a smaller volume{}", bytes.div_ceil(1 << 20), limit >> 20, if *layout == "embedded" { ", or the packed layout (one word per sample)" } else { "" })]
    FourDTooLarge { bytes: usize, limit: usize, layout: &'static str },
    /// 4D samples asked for in a layout a storage buffer cannot take.
    #[error("4D samples are a storage buffer: the {layout} layout is not offered; use the embedded or packed layout")]
    FourDLayout { layout: &'static str },
    /// A time series with no frame.
    #[error("time series: a time series needs at least one frame")]
    SeriesEmpty,
    /// A time series past the address space.
    #[error("time series: {frames} frames of {}x{}x{} are too many samples to address", dims[0], dims[1], dims[2])]
    SeriesTooLarge { dims: [usize; 3], frames: usize },
    /// Series data whose length does not match its dims.
    #[error("time series: {len} values for {frames} frames of {}x{}x{} need {expected}: build it with matching dims and data", dims[0], dims[1], dims[2])]
    SeriesLength { dims: [usize; 3], frames: usize, len: usize, expected: usize },
    /// Frames of different dims.
    #[error("time series: frame {frame} is {}x{}x{} but frame 0 is {}x{}x{}: every frame of a series has the same dims", dims[0], dims[1], dims[2], first[0], first[1], first[2])]
    SeriesFrameDims { frame: usize, dims: [usize; 3], first: [usize; 3] },
    /// A file whose rank is not (x, y, z, t).
    #[error("time series: {path} holds {}-D data with dims {shape:?}: a time series is one 3-D volume per time point (x, y, z, t)", shape.len())]
    SeriesRank { path: PathBuf, shape: Vec<usize> },
    /// A frame file without a number in its name.
    #[error(
        "time series: {path} has no frame number in its name: name the frames with their number, e.g. frame_007.raw"
    )]
    SeriesFrameName { path: PathBuf },
    /// A folder without frames.
    #[error(
        "time series: {dir} holds no .raw files: give a folder of numbered frames (frame_000.raw, frame_001.raw, ...)"
    )]
    SeriesNoFrames { dir: PathBuf },
    /// Two files with one frame number.
    #[error("time series: {first} and {second} both claim frame {frame}: keep one file per frame number")]
    SeriesDuplicate { first: PathBuf, second: PathBuf, frame: u64 },
    /// A filter applied to samples on another lattice (a prefilter, or a
    /// store of lattice samples drawn with another lattice's filter).
    #[error("filter {filter} is defined on the {filter_lattice} lattice, but the samples are on the {data_lattice} lattice: pick a filter on {data_lattice} (boxforge list shows each filter's lattice)")]
    LatticeMismatch { filter: String, filter_lattice: String, data_lattice: String },
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

#[cfg(feature = "zarr")]
impl From<super::zarr::ZarrError> for VolumeError {
    fn from(e: super::zarr::ZarrError) -> VolumeError {
        VolumeError::Zarr(Box::new(e))
    }
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
