//! An OME-Zarr image opened from a folder: its multiscales metadata and
//! each level's array, checked against each other once at open (so a
//! renderer never meets a level whose shape contradicts its scale).

use super::cosets::LatticeLayout;
use super::meta::{AxisKind, Multiscale};
use super::{ZarrError, ZarrType};
use std::path::{Path, PathBuf};
use std::sync::Arc;
use zarrs::array::Array;
use zarrs::storage::ReadableStorageTraits;

/// The storage the reader works on (a folder today; any zarrs store fits).
pub(super) type Storage = dyn ReadableStorageTraits;

/// Whether `path` names an OME-Zarr store rather than a volume file: a
/// folder holding `zarr.json` (Zarr v3) or `.zattrs`/`.zgroup` (Zarr v2),
/// or any path ending in `.zarr`.
pub fn is_store(path: &Path) -> bool {
    let named = path.to_str().map(|s| s.trim_end_matches('/').to_ascii_lowercase().ends_with(".zarr")).unwrap_or(false);
    named || url_of(path).is_some() || ["zarr.json", ".zattrs", ".zgroup"].iter().any(|f| path.join(f).is_file())
}

/// The URL `path` spells, if it is one (`http://` or `https://`).
fn url_of(path: &Path) -> Option<&str> {
    path.to_str().filter(|s| s.starts_with("http://") || s.starts_with("https://"))
}

/// The most samples a level may declare (2^40, a 10240^3 volume): past
/// it no renderer's page table or bounds pass is sane, and a shape that
/// large in a store is far more likely a broken header than data.
pub const MAX_LEVEL_SAMPLES: u64 = 1 << 40;

/// One resolution level: its array and its shape.
pub struct ZarrLevel {
    pub(super) array: Arc<Array<Storage>>,
    /// The array's path inside the store.
    pub path: String,
    /// Voxels along (x, y, z).
    pub dims: [usize; 3],
    /// Physical voxel size along (x, y, z).
    pub spacing: [f64; 3],
    /// Stored sample type.
    pub ty: ZarrType,
}

/// Which level, channel and time point of an image to read.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Selection {
    /// Resolution level (0: finest).
    pub level: usize,
    /// Channel index (0 when the image has no channel axis).
    pub channel: usize,
    /// Time point (0 when the image has no time axis).
    pub time: usize,
}

/// An OME-Zarr image: metadata and levels, opened and checked.
pub struct OmeZarr {
    path: PathBuf,
    meta: Multiscale,
    /// Each array axis's length at level 0.
    shape0: Vec<u64>,
    levels: Vec<ZarrLevel>,
    /// For a store of lattice samples (`convert --lattice`), their layout.
    layout: Option<LatticeLayout>,
}

impl OmeZarr {
    /// Opens the OME-Zarr image in the folder `path` (Zarr v2 or v3), or at
    /// the URL it spells (`http://`, with the `http` feature).
    pub fn open(path: &Path) -> Result<OmeZarr, ZarrError> {
        if let Some(url) = url_of(path) {
            return Self::open_url(url);
        }
        let store = zarrs::filesystem::FilesystemStore::new(path)
            .map_err(|e| ZarrError::Open { path: path.to_path_buf(), reason: e.to_string() })?;
        if !path.is_dir() {
            return Err(ZarrError::Open { path: path.to_path_buf(), reason: "no such folder".into() });
        }
        let storage: Arc<Storage> = Arc::new(store);
        Self::open_storage(path, storage)
    }

    /// Opens the image at `url` over HTTP, chunks fetched on demand.
    #[cfg(feature = "http")]
    pub fn open_url(url: &str) -> Result<OmeZarr, ZarrError> {
        if url.starts_with("https://") {
            return Err(ZarrError::NoTls { url: url.to_string() });
        }
        let store = Arc::new(super::http::HttpStore::new(url, super::http::HttpOptions::default()));
        let image = Self::open_storage(Path::new(url), store.clone())?;
        let sharded = image
            .levels
            .iter()
            .any(|l| serde_json::to_string(l.array.metadata()).is_ok_and(|m| m.contains("sharding_indexed")));
        if sharded {
            let key = zarrs::storage::StoreKey::new("zarr.json").expect("a valid key");
            let honoured = store
                .honours_range(&key)
                .map_err(|e| ZarrError::Open { path: PathBuf::from(url), reason: e.to_string() })?;
            if !honoured {
                return Err(ZarrError::RangeIgnored { url: url.to_string() });
            }
        }
        Ok(image)
    }

    /// Without the `http` feature a URL is refused.
    #[cfg(not(feature = "http"))]
    pub fn open_url(url: &str) -> Result<OmeZarr, ZarrError> {
        Err(ZarrError::NotBuilt { url: url.to_string(), feature: "http" })
    }

    /// Opens an image from any zarrs store (`path` names it in messages).
    pub(super) fn open_storage(path: &Path, storage: Arc<Storage>) -> Result<OmeZarr, ZarrError> {
        let group = zarrs::group::Group::open(storage.clone(), "/")
            .map_err(|e| ZarrError::Open { path: path.to_path_buf(), reason: e.to_string() })?;
        let meta = Multiscale::from_attributes(path, group.attributes())?;
        let layout = LatticeLayout::from_attributes(path, group.attributes())?;
        let rank = meta.axes.len();
        let mut levels = Vec::with_capacity(meta.levels.len());
        let mut shape0 = Vec::new();
        for (i, level) in meta.levels.iter().enumerate() {
            let key = format!("/{}", level.path.trim_matches('/'));
            let array = Array::open(storage.clone(), &key).map_err(|e| ZarrError::Array {
                path: path.to_path_buf(),
                level: level.path.clone(),
                reason: e.to_string(),
            })?;
            let shape = array.shape().to_vec();
            if shape.len() != rank {
                return Err(ZarrError::Rank {
                    path: path.to_path_buf(),
                    level: level.path.clone(),
                    rank: shape.len(),
                    axes: rank,
                });
            }
            let ty = ZarrType::of(array.data_type()).ok_or_else(|| ZarrError::DataType {
                path: path.to_path_buf(),
                level: level.path.clone(),
                data_type: array.data_type().to_string(),
            })?;
            let zyx = [shape[rank - 3], shape[rank - 2], shape[rank - 1]];
            let samples = zyx.iter().try_fold(1u64, |n, &e| n.checked_mul(e));
            if samples.is_none_or(|n| n > MAX_LEVEL_SAMPLES) || zyx.contains(&0) {
                return Err(ZarrError::ShapePastLimit {
                    path: path.to_path_buf(),
                    level: level.path.clone(),
                    shape: zyx,
                });
            }
            if let Some(l) = &layout {
                check_lattice_level(path, &meta, l, i, &shape)?;
            } else if i > 0 {
                check_level_shape(path, &meta, i, zyx, &shape0)?;
            }
            if i == 0 {
                shape0 = shape.clone();
            }
            let s = level.scale_zyx;
            levels.push(ZarrLevel {
                array: Arc::new(array),
                path: level.path.clone(),
                dims: [zyx[2] as usize, zyx[1] as usize, zyx[0] as usize],
                spacing: [s[2], s[1], s[0]],
                ty,
            });
        }
        if let Some(l) = layout.as_ref().filter(|l| l.dims.len() != levels.len()) {
            let what =
                format!("its boxforge attribute lists {} levels and the multiscales {}", l.dims.len(), levels.len());
            return Err(ZarrError::LatticeLayout { path: path.to_path_buf(), cosets: l.cosets.len(), what });
        }
        Ok(OmeZarr { path: path.to_path_buf(), meta, shape0, levels, layout })
    }

    /// The store's folder.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// The parsed metadata.
    pub fn metadata(&self) -> &Multiscale {
        &self.meta
    }

    /// The levels, finest first.
    pub fn levels(&self) -> &[ZarrLevel] {
        &self.levels
    }

    /// For a store of lattice samples (`boxforge convert --lattice`), how
    /// they are laid out: its channels are the lattice's cosets.
    pub fn layout(&self) -> Option<&LatticeLayout> {
        self.layout.as_ref()
    }

    /// Channels (1 without a channel axis, and for a store of lattice
    /// samples, whose channel axis holds the cosets).
    pub fn channels(&self) -> usize {
        if self.layout.is_some() {
            return 1;
        }
        self.count_of(AxisKind::Channel)
    }

    /// Time points (1 without a time axis).
    pub fn times(&self) -> usize {
        self.count_of(AxisKind::Time)
    }

    fn count_of(&self, kind: AxisKind) -> usize {
        self.meta.axes.iter().position(|k| *k == kind).map_or(1, |i| self.shape0[i] as usize)
    }

    /// Checks a selection against the store's levels, channels and times.
    pub fn check(&self, s: Selection) -> Result<(), ZarrError> {
        let index = |what, index, count| {
            if index < count {
                Ok(())
            } else {
                Err(ZarrError::Index { path: self.path.clone(), what, index, count })
            }
        };
        index("levels", s.level, self.levels.len())?;
        index("channels", s.channel, self.channels())?;
        index("time points", s.time, self.times())
    }

    /// The array indices of the non-space axes for a selection, in axis order.
    pub(super) fn prefix(&self, s: Selection) -> Vec<u64> {
        self.meta
            .axes
            .iter()
            .filter_map(|k| match k {
                AxisKind::Channel if self.layout.is_some() => None,
                AxisKind::Channel => Some(s.channel as u64),
                AxisKind::Time => Some(s.time as u64),
                AxisKind::Space => None,
            })
            .collect()
    }
}

/// A coarser level's (z, y, x) shape must be level 0's divided by the ratio
/// of their scales, within one voxel of the coarse level (writers round
/// either way: `ceil(n / 2)` by subsampling, `floor(n / 2)` by averaging).
fn check_level_shape(path: &Path, meta: &Multiscale, i: usize, zyx: [u64; 3], shape0: &[u64]) -> Result<(), ZarrError> {
    let r = shape0.len();
    let zyx0 = [shape0[r - 3], shape0[r - 2], shape0[r - 1]];
    let (s0, s) = (meta.levels[0].scale_zyx, meta.levels[i].scale_zyx);
    let expected: [f64; 3] = std::array::from_fn(|a| zyx0[a] as f64 * s0[a] / s[a]);
    if (0..3).any(|a| (zyx[a] as f64 - expected[a]).abs() > 1.0 + 1e-6) {
        return Err(ZarrError::LevelShape {
            path: path.to_path_buf(),
            level: meta.levels[i].path.clone(),
            shape: zyx,
            expected,
        });
    }
    Ok(())
}

/// A lattice store's level `i`: axes (c, z, y, x) with one channel per
/// coset (or (z, y, x) for one), and the cosets' grid of the level's
/// lattice box as its shape, exactly.
fn check_lattice_level(
    path: &Path,
    meta: &Multiscale,
    l: &LatticeLayout,
    i: usize,
    shape: &[u64],
) -> Result<(), ZarrError> {
    let fail = |what: String| ZarrError::LatticeLayout { path: path.to_path_buf(), cosets: l.cosets.len(), what };
    let lead: Vec<AxisKind> = if l.cosets.len() > 1 { vec![AxisKind::Channel] } else { vec![] };
    let axes = [lead, vec![AxisKind::Space; 3]].concat();
    if meta.axes != axes {
        return Err(fail(format!("its axes are {:?}", meta.axis_names)));
    }
    let Some(&dims) = l.dims.get(i) else {
        return Err(fail(format!("its boxforge attribute has no level {i}")));
    };
    let grid = l.coset_shape(dims);
    let lead: Vec<u64> = if l.cosets.len() > 1 { vec![l.cosets.len() as u64] } else { vec![] };
    let expected = [lead, vec![grid[2] as u64, grid[1] as u64, grid[0] as u64]].concat();
    if shape != expected.as_slice() {
        return Err(fail(format!(
            "level '{}' has shape {shape:?} where a lattice box of {dims:?} (x, y, z) calls for {expected:?}",
            meta.levels[i].path
        )));
    }
    Ok(())
}
