//! One level, channel and time point of an OME-Zarr image read box by box
//! as its lattice subset, through an LRU cache of decoded chunks: the
//! bricks of a frame share chunks (and their halos overlap), and a chunk is
//! decoded once while it stays in the cache.

use super::store::{OmeZarr, Selection, Storage};
use super::{ZarrError, ZarrType};
use crate::volume::convert::Membership;
use crate::volume::source::check_box_len;
use crate::volume::{BrickSource, Volume, VolumeError};
use boxforge::spec::lattice::Lattice;
use std::path::PathBuf;
use std::sync::{Arc, OnceLock};
use zarrs::array::chunk_cache::{ChunkCache, ChunkCacheLruSizeLimit, ChunkCacheTypeDecoded};
use zarrs::array::{Array, ArraySubset};

/// Default bytes of decoded chunks kept (per volume).
pub const DEFAULT_CHUNK_CACHE: u64 = 64 << 20;

/// A level of an OME-Zarr image as lattice samples (the sample at lattice
/// points, 0 elsewhere; the values as stored, converted to f32).
///
/// **Host memory bound.** The decoded-chunk cache (at most
/// [`DEFAULT_CHUNK_CACHE`] bytes, or what [`ZarrVolume::with_cache`] says),
/// the box being read and the lattice's membership table.
pub struct ZarrVolume {
    path: PathBuf,
    level_path: String,
    array: Arc<Array<Storage>>,
    cache: ChunkCacheLruSizeLimit<ChunkCacheTypeDecoded>,
    cache_bytes: u64,
    prefix: Vec<u64>,
    dims: [usize; 3],
    spacing: [f64; 3],
    unit: Option<String>,
    ty: ZarrType,
    lattice: Lattice,
    member: Membership,
    range: OnceLock<(f32, f32)>,
    identity: Option<String>,
    /// A store of lattice samples: how to find a lattice point's coset.
    cosets: Option<CosetIndex>,
}

/// Where a lattice store keeps each lattice point: channel `table[j mod
/// period]` at index j / period (`cosets.rs`).
struct CosetIndex {
    period: [usize; 3],
    table: Vec<Option<usize>>,
    count: usize,
}

impl ZarrVolume {
    /// The selected level, channel and time point of `image` on `lattice`.
    pub fn new(image: &OmeZarr, s: Selection, lattice: &Lattice) -> Result<ZarrVolume, VolumeError> {
        Self::with_cache(image, s, lattice, DEFAULT_CHUNK_CACHE)
    }

    /// As [`new`](Self::new), with a decoded-chunk cache of `cache_bytes`.
    pub fn with_cache(
        image: &OmeZarr,
        s: Selection,
        lattice: &Lattice,
        cache_bytes: u64,
    ) -> Result<ZarrVolume, VolumeError> {
        image.check(s)?;
        let level = &image.levels()[s.level];
        let (mut dims, mut spacing, mut cosets) = (level.dims, level.spacing, None);
        if let Some(l) = image.layout() {
            if !l.stores(lattice) {
                let (path, stored, asked) = (image.path().to_path_buf(), l.lattice.clone(), lattice.name.clone());
                return Err(ZarrError::LatticeStore { path, stored, asked }.into());
            }
            dims = l.dims[s.level];
            spacing = std::array::from_fn(|a| spacing[a] / l.period[a] as f64);
            cosets = Some(CosetIndex { period: l.period, table: l.channel_table(), count: l.cosets.len() });
        }
        let erased: Arc<Array<Storage>> = level.array.clone();
        let identity = store_identity(image.path()).map(|id| format!("{id}|{:?}|{}", s, lattice.name));
        Ok(ZarrVolume {
            path: image.path().to_path_buf(),
            level_path: level.path.clone(),
            cache: ChunkCacheLruSizeLimit::new(erased.clone(), cache_bytes),
            array: erased,
            cache_bytes,
            prefix: image.prefix(s),
            dims,
            spacing,
            unit: image.metadata().space_unit.clone(),
            ty: level.ty,
            lattice: lattice.clone(),
            member: Membership::new(lattice)?,
            range: OnceLock::new(),
            identity,
            cosets,
        })
    }

    /// Physical voxel size along (x, y, z), from the store's scale.
    pub fn spacing(&self) -> [f64; 3] {
        self.spacing
    }

    /// The unit of [`Self::spacing`] the store's space axes give, if any.
    pub fn space_unit(&self) -> Option<&str> {
        self.unit.as_deref()
    }

    /// The stored sample type.
    pub fn sample_type(&self) -> ZarrType {
        self.ty
    }

    /// Whether the store holds lattice samples (`convert --lattice`)
    /// rather than a Cartesian image.
    pub fn is_lattice_store(&self) -> bool {
        self.cosets.is_some()
    }

    /// The whole level as lattice samples: for the in-memory renderers.
    /// Checks the sample count first.
    pub fn to_lattice_volume(&self) -> Result<crate::volume::LatticeVolume, VolumeError> {
        self.check_in_memory()?;
        let mut data = vec![0f32; self.dims.iter().product()];
        self.read_box([0, 0, 0], self.dims, &mut data)?;
        Ok(crate::volume::LatticeVolume { lattice: self.lattice.clone(), dims: self.dims, data })
    }

    fn check_in_memory(&self) -> Result<(), VolumeError> {
        if crate::limits::check_samples(self.dims, "").is_err() {
            let (path, level) = (self.path.clone(), self.level_path.clone());
            return Err(ZarrError::LevelTooLarge { path, level, dims: self.dims }.into());
        }
        Ok(())
    }

    /// The whole level as a Cartesian volume (the stored values, every
    /// voxel): for the in-memory renderers. Checks the sample count first;
    /// a store of lattice samples is read with [`Self::to_lattice_volume`].
    pub fn to_volume(&self) -> Result<Volume, VolumeError> {
        if self.cosets.is_some() {
            let (path, stored) = (self.path.clone(), self.lattice.name.clone());
            return Err(ZarrError::LatticeStore { path, stored, asked: "Cartesian".into() }.into());
        }
        self.check_in_memory()?;
        let data = self.read_clamped([0, 0, 0], self.dims.map(|n| n - 1), false)?;
        Volume::new(self.dims, data)
    }

    fn err(&self, reason: impl std::fmt::Display) -> VolumeError {
        ZarrError::Read { path: self.path.clone(), level: self.level_path.clone(), reason: reason.to_string() }.into()
    }

    /// The stored samples in the box [lo, hi] (inclusive, inside the
    /// array; x fastest) as f32, through the chunk cache or straight from
    /// the store (`cached` false: a one-pass read that should not evict).
    fn read_clamped(&self, lo: [usize; 3], hi: [usize; 3], cached: bool) -> Result<Vec<f32>, VolumeError> {
        let mut ranges: Vec<std::ops::Range<u64>> = self.prefix.iter().map(|&i| i..i + 1).collect();
        for a in [2, 1, 0] {
            ranges.push(lo[a] as u64..hi[a] as u64 + 1);
        }
        self.read_ranges(&ranges, cached)
    }

    /// The stored samples of an array subset, as f32.
    fn read_ranges(&self, ranges: &[std::ops::Range<u64>], cached: bool) -> Result<Vec<f32>, VolumeError> {
        let subset = ArraySubset::new_with_ranges(ranges);
        macro_rules! read {
            ($t:ty) => {{
                let v: Vec<$t> = if cached {
                    self.cache
                        .retrieve_array_subset(&subset, &zarrs::array::CodecOptions::default())
                        .map_err(|e| self.err(e))?
                } else {
                    self.array.retrieve_array_subset(&subset).map_err(|e| self.err(e))?
                };
                v.into_iter().map(|x| x as f32).collect::<Vec<f32>>()
            }};
        }
        Ok(match self.ty {
            ZarrType::U8 => read!(u8),
            ZarrType::U16 => read!(u16),
            ZarrType::I16 => read!(i16),
            ZarrType::F32 => read!(f32),
        })
    }

    fn non_finite(&self, voxel: [usize; 3]) -> VolumeError {
        ZarrError::NonFinite { path: self.path.clone(), level: self.level_path.clone(), voxel }.into()
    }
}

impl ZarrVolume {
    /// [`BrickSource::read_box`] of a lattice store: the box's lattice
    /// points read from their cosets' channels (one read of every channel
    /// over the coset grid's box), 0 elsewhere.
    fn read_coset_box(
        &self,
        c: &CosetIndex,
        lo: [i64; 3],
        size: [usize; 3],
        out: &mut [f32],
    ) -> Result<(), VolumeError> {
        let clamp = |v: i64, n: usize| v.clamp(0, n as i64 - 1) as usize;
        let p = c.period;
        let first: [usize; 3] = std::array::from_fn(|a| clamp(lo[a], self.dims[a]) / p[a]);
        let last: [usize; 3] =
            std::array::from_fn(|a| clamp(lo[a].saturating_add(size[a] as i64 - 1), self.dims[a]) / p[a]);
        let mut ranges: Vec<std::ops::Range<u64>> = (c.count > 1).then_some(0..c.count as u64).into_iter().collect();
        ranges.extend([2, 1, 0].map(|a| first[a] as u64..last[a] as u64 + 1));
        let data = self.read_ranges(&ranges, true)?;
        let w: [usize; 3] = std::array::from_fn(|a| last[a] - first[a] + 1);
        let plane = w[0] * w[1] * w[2];
        let mut i = 0;
        for dz in 0..size[2] {
            let z = clamp(lo[2].saturating_add(dz as i64), self.dims[2]);
            for dy in 0..size[1] {
                let y = clamp(lo[1].saturating_add(dy as i64), self.dims[1]);
                for dx in 0..size[0] {
                    let x = clamp(lo[0].saturating_add(dx as i64), self.dims[0]);
                    let j = [x, y, z];
                    let residue = (x % p[0]) + p[0] * ((y % p[1]) + p[1] * (z % p[2]));
                    out[i] = match c.table[residue] {
                        Some(channel) => {
                            let g: [usize; 3] = std::array::from_fn(|a| j[a] / p[a] - first[a]);
                            let v = data[channel * plane + g[0] + w[0] * (g[1] + w[1] * g[2])];
                            if !v.is_finite() {
                                return Err(self.non_finite(j));
                            }
                            v
                        }
                        None => 0.0,
                    };
                    i += 1;
                }
            }
        }
        Ok(())
    }
}

/// The store's folder, canonical, with its `zarr.json`/`.zattrs`
/// modification time: a rewritten store reads as a new one.
fn store_identity(path: &std::path::Path) -> Option<String> {
    let canonical = std::fs::canonicalize(path).ok()?;
    let meta = ["zarr.json", ".zattrs"].iter().find_map(|f| std::fs::metadata(path.join(f)).ok())?;
    let nanos = meta.modified().ok()?.duration_since(std::time::UNIX_EPOCH).ok()?.as_nanos();
    Some(format!("zarr|{}|{nanos}", canonical.display()))
}

impl BrickSource for ZarrVolume {
    fn dims(&self) -> [usize; 3] {
        self.dims
    }

    fn lattice(&self) -> &Lattice {
        &self.lattice
    }

    fn read_box(&self, lo: [i64; 3], size: [usize; 3], out: &mut [f32]) -> Result<(), VolumeError> {
        check_box_len(size, out.len())?;
        if out.is_empty() {
            return Ok(());
        }
        if let Some(c) = &self.cosets {
            return self.read_coset_box(c, lo, size, out);
        }
        let clamp = |v: i64, n: usize| v.clamp(0, n as i64 - 1) as usize;
        let first: [usize; 3] = std::array::from_fn(|a| clamp(lo[a], self.dims[a]));
        let last: [usize; 3] = std::array::from_fn(|a| clamp(lo[a].saturating_add(size[a] as i64 - 1), self.dims[a]));
        let data = self.read_clamped(first, last, true)?;
        let (wx, wy) = (last[0] - first[0] + 1, last[1] - first[1] + 1);
        let mut i = 0;
        for dz in 0..size[2] {
            let z = clamp(lo[2].saturating_add(dz as i64), self.dims[2]);
            for dy in 0..size[1] {
                let y = clamp(lo[1].saturating_add(dy as i64), self.dims[1]);
                let row = ((z - first[2]) * wy + (y - first[1])) * wx;
                for dx in 0..size[0] {
                    let x = clamp(lo[0].saturating_add(dx as i64), self.dims[0]);
                    out[i] = if self.member.contains([x, y, z]) {
                        let v = data[row + x - first[0]];
                        if !v.is_finite() {
                            return Err(self.non_finite([x, y, z]));
                        }
                        v
                    } else {
                        0.0
                    };
                    i += 1;
                }
            }
        }
        Ok(())
    }

    /// One pass over the level in slabs of the array's chunk depth (not
    /// through the cache: the pass would only evict what frames use).
    fn sample_range(&self) -> Result<(f32, f32), VolumeError> {
        if self.cosets.is_some() {
            return crate::volume::lattice_sources::remembered_range(&self.range, self, &self.member);
        }
        if let Some(&r) = self.range.get() {
            return Ok(r);
        }
        let rank = self.prefix.len() + 3;
        let origin = vec![0u64; rank];
        let chunk = self.array.chunk_shape(&origin).map_err(|e| self.err(e))?;
        let edge = |a: usize| chunk[rank - 1 - a].get() as usize;
        let step = [edge(0), edge(1), edge(2)];
        let (mut lo, mut hi) = (f32::INFINITY, f32::NEG_INFINITY);
        for z0 in (0..self.dims[2]).step_by(step[2]) {
            for y0 in (0..self.dims[1]).step_by(step[1]) {
                for x0 in (0..self.dims[0]).step_by(step[0]) {
                    let first = [x0, y0, z0];
                    let last: [usize; 3] = std::array::from_fn(|a| (first[a] + step[a]).min(self.dims[a]) - 1);
                    let data = self.read_clamped(first, last, false)?;
                    let w = [last[0] - x0 + 1, last[1] - y0 + 1];
                    for (k, &v) in data.iter().enumerate() {
                        let j = [x0 + k % w[0], y0 + (k / w[0]) % w[1], z0 + k / (w[0] * w[1])];
                        if !self.member.contains(j) {
                            continue;
                        }
                        if !v.is_finite() {
                            return Err(self.non_finite(j));
                        }
                        lo = lo.min(v);
                        hi = hi.max(v);
                    }
                }
            }
        }
        let r = if lo <= hi { (lo, hi) } else { (0.0, 0.0) };
        Ok(*self.range.get_or_init(|| r))
    }

    fn resident_bytes(&self) -> usize {
        self.cache_bytes as usize + self.member.table_bytes()
    }

    fn identity(&self) -> Option<String> {
        self.identity.clone()
    }
}
