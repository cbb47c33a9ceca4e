//! What can go wrong with an OME-Zarr store; each message names the store,
//! the problem and what to do.

use std::path::PathBuf;

/// An OME-Zarr store that cannot be read or written.
#[derive(Debug, thiserror::Error)]
pub enum ZarrError {
    /// The path is not a Zarr group (no `zarr.json` or `.zgroup`).
    #[error("cannot open {path} as a Zarr group: {reason} (give the folder of an OME-Zarr image, the one holding zarr.json or .zattrs)")]
    Open { path: PathBuf, reason: String },
    /// A Zarr group without OME `multiscales` metadata.
    #[error("{path} is a Zarr group without OME-Zarr multiscales metadata: give the folder of an OME-Zarr image (0.4 or 0.5), not of a plate, a label group or a bare array")]
    NotOme { path: PathBuf },
    /// OME metadata that does not parse or does not describe a volume.
    #[error("{path}: bad OME-Zarr metadata: {reason}; fix the store's multiscales metadata (e.g. validate it with ome-zarr-models)")]
    Metadata { path: PathBuf, reason: String },
    /// Axes that are not (t?, c?, z, y, x).
    #[error("{path} has axes {axes:?}: boxforge reads images with three space axes last and at most one time and one channel axis before them, e.g. [t, c, z, y, x]")]
    Axes { path: PathBuf, axes: Vec<String> },
    /// A coarser level with a finer scale than the level before it.
    #[error("{path}: level '{coarser}' has scale {coarser_scale:?} (z, y, x), finer than the level before it ({finer_scale:?}): list the levels finest first, each as coarse as the one before or coarser")]
    LevelOrder { path: PathBuf, coarser: String, finer_scale: [f64; 3], coarser_scale: [f64; 3] },
    /// A level whose shape does not match its scale against level 0.
    #[error("{path}: level '{level}' has {shape:?} voxels (z, y, x), but level 0's shape and the two levels' scales call for about {expected:?}: the levels' shapes and scales are inconsistent; rewrite the pyramid (e.g. with boxforge convert)")]
    LevelShape { path: PathBuf, level: String, shape: [u64; 3], expected: [f64; 3] },
    /// A level's array could not be opened.
    #[error("{path}: cannot open level '{level}' as a Zarr array: {reason} (check that the store is complete and was written by a Zarr v2 or v3 writer)")]
    Array { path: PathBuf, level: String, reason: String },
    /// A level's array rank differs from the axes'.
    #[error("{path}: level '{level}' has {rank} dimensions but the image has {axes} axes: rewrite the store so every level has one dimension per axis")]
    Rank { path: PathBuf, level: String, rank: usize, axes: usize },
    /// A sample type boxforge does not read.
    #[error("{path}: level '{level}' stores {data_type} samples: boxforge reads uint8, uint16, int16 and float32; convert the store to one of those")]
    DataType { path: PathBuf, level: String, data_type: String },
    /// A level, channel or time point past the store's.
    #[error("{path} has {count} {what} (0 to {}), so there is no {index}: pick one of those", count.saturating_sub(1))]
    Index { path: PathBuf, what: &'static str, index: usize, count: usize },
    /// Chunks that could not be read or decoded (a corrupt or truncated chunk, a store error).
    #[error("{path}: reading level '{level}' failed: {reason} (a chunk may be corrupt or truncated; rewrite or re-download the store)")]
    Read { path: PathBuf, level: String, reason: String },
    /// A non-finite sample at a lattice point.
    #[error("{path}: level '{level}' has a NaN or infinite sample at voxel {voxel:?} (x, y, z): boxforge needs finite samples; replace them in the store")]
    NonFinite { path: PathBuf, level: String, voxel: [usize; 3] },
    /// A level whose declared shape is past what any renderer addresses.
    #[error("{path}: level '{level}' declares {shape:?} samples (z, y, x), past the {} samples boxforge addresses in one volume: check the store's array metadata (shape)", super::store::MAX_LEVEL_SAMPLES)]
    ShapePastLimit { path: PathBuf, level: String, shape: [u64; 3] },
    /// A level too large to read whole into memory.
    #[error("{path}: level '{level}' has {}x{}x{} samples, too many to read into memory at once: read a coarser level of the pyramid, or render this one out of core within a GPU memory budget", dims[0], dims[1], dims[2])]
    LevelTooLarge { path: PathBuf, level: String, dims: [usize; 3] },
    /// Creating or writing the output store failed.
    #[error("cannot write {path}: {reason} (check that its folder is writable and the disk has room)")]
    Write { path: PathBuf, reason: String },
    /// The output exists and is not an empty folder.
    #[error("{path} exists: remove it first or write to a new path (boxforge does not overwrite a store)")]
    Exists { path: PathBuf },
    /// A URL while the `http` feature is off.
    #[error("{url}: this build of boxforge-runtime reads no URLs: build it with the '{feature}' feature, or copy the store to a folder")]
    NotBuilt { url: String, feature: &'static str },
    /// A sharded store on a server that ignores Range requests.
    #[error("{url} is sharded, but its server ignores Range requests (it answers with whole files): serve it with a server that honours Range (nginx, Apache, a cloud bucket; not Python's http.server), or convert it unsharded")]
    RangeIgnored { url: String },
    /// An `https://` URL (no TLS client is built in).
    #[error("{url}: boxforge reads stores over plain http:// only (no TLS client is built in): serve the store over http on a trusted network, or copy it to a folder")]
    NoTls { url: String },
    /// Prefiltered coefficients asked for in an integer type.
    #[error("prefiltered samples are spline coefficients, which leave the samples' range (negative lobes, overshoot): store them as float32, not {ty}")]
    CoefficientType { ty: &'static str },
    /// A store of lattice samples read on another lattice.
    #[error("{path} holds {stored} lattice samples, not {asked} ones: draw it with a filter on {stored} (boxforge list shows each filter's lattice)")]
    LatticeStore { path: PathBuf, stored: String, asked: String },
    /// A store of lattice samples in a layout this reader does not take.
    #[error("{path}: a store of lattice samples must have axes [c, z, y, x] with one channel per coset ({cosets}) and each level's shape its cosets' grid, but {what}: rewrite the store (boxforge convert writes this layout)")]
    LatticeLayout { path: PathBuf, cosets: usize, what: String },
    /// A store of lattice samples asked to be resampled again.
    #[error("{path} already holds {lattice} lattice samples, resampled when the store was written: read them as they are, without resampling")]
    AlreadyResampled { path: PathBuf, lattice: String },
    /// A bad pyramid option.
    #[error("pyramid option {option} = {value}: {need}")]
    Option { option: &'static str, value: u64, need: &'static str },
}
