//! A store's plan: the levels, arrays and metadata of a pyramid that
//! `boxforge convert` writes, cut into write units (a chunk, or a shard when
//! sharded) that independent writers fill in any order, each unit once.
//!
//! [`write_pyramid`](super::write_pyramid) and
//! [`write_lattice_pyramid`](super::write_lattice_pyramid) write every unit
//! in turn; a Dask cluster (`boxforge.dask.to_ome_zarr` in the Python
//! package) writes them from many processes. Both go through
//! [`StorePlan::create`], [`StorePlan::write_unit`] and
//! [`StorePlan::finish`], so the two stores are the same bytes. Units never
//! share a file (a chunk, or a shard holding whole chunks), so concurrent
//! writers need no lock; the group metadata is written last, so a store
//! that looks complete is complete.

use super::cosets::LatticeLayout;
use super::write::{create_array, open_level, store_values, write_group, Reduced, StoredLevel};
use super::{OmeZarr, PyramidOptions, PyramidReport, Reduction, Selection, ZarrError, ZarrType, ZarrVolume};
use crate::volume::{matched_lattice, BrickSource, Prefiltered, Resampled, VolumeError, Window};
use boxforge::derive::Derivation;
use boxforge::spec::lattice::Lattice;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use zarrs::array::codec::array_to_bytes::sharding::{ShardingCodecOptions, SubchunkWriteOrder};
use zarrs::array::{Array, ArraySubset, CodecSpecificOptions};
use zarrs::filesystem::FilesystemStore;

/// The folder inside a lattice store that holds the float32 Cartesian
/// pyramid while the lattice levels are made from it.
const CARTESIAN_PASS: &str = ".boxforge-cartesian";

/// The levels, array shapes and metadata of a store, before and while it is written.
#[derive(Clone, Debug)]
pub struct StorePlan {
    out: PathBuf,
    options: PyramidOptions,
    cartesian: Vec<[usize; 3]>,
    lattice: Option<LatticePlan>,
}

#[derive(Clone, Debug)]
struct LatticePlan {
    layout: LatticeLayout,
    /// Each level's lattice box and scale (Cartesian voxels per lattice unit).
    matched: Vec<([usize; 3], f64)>,
    lattice: Lattice,
}

/// The Cartesian levels' dims (x, y, z) of a pyramid of `dims`: halved by
/// the reduction until the largest edge fits one chunk, or `levels` of them.
pub fn pyramid_dims(dims: [usize; 3], o: &PyramidOptions) -> Vec<[usize; 3]> {
    let mut out = vec![dims];
    loop {
        let last = *out.last().expect("level 0");
        let more = match o.levels {
            Some(n) => out.len() < n,
            None => last.iter().copied().max().unwrap_or(1) > o.chunk,
        };
        if !more {
            return out;
        }
        out.push(last.map(|n| o.reduction.next_len(n)));
    }
}

impl StorePlan {
    /// The plan of a store at `out` of a Cartesian volume of `dims` (x, y,
    /// z): of its samples, or with `lattice`, of each level resampled on
    /// the lattice (and prefiltered for the filter named `prefilter`, a
    /// name the store records).
    pub fn new(
        out: &Path,
        dims: [usize; 3],
        o: &PyramidOptions,
        lattice: Option<(&Lattice, Option<String>)>,
    ) -> Result<StorePlan, VolumeError> {
        super::write::check_options(o)?;
        crate::volume::error::checked_count(dims)?;
        if dims.contains(&0) {
            return Err(VolumeError::BadDims { dims, reason: "a store needs at least one sample per axis".into() });
        }
        let cartesian = pyramid_dims(dims, o);
        let lattice = match lattice {
            None => None,
            Some((l, prefilter)) => {
                if prefilter.is_some() && o.ty != ZarrType::F32 {
                    return Err(ZarrError::CoefficientType { ty: o.ty.name() }.into());
                }
                let matched: Vec<([usize; 3], f64)> = cartesian.iter().map(|&d| matched_lattice(l, d)).collect();
                let layout = LatticeLayout::new(l, matched.iter().map(|m| m.0).collect(), prefilter)?;
                Some(LatticePlan { layout, matched, lattice: l.clone() })
            }
        };
        Ok(StorePlan { out: out.to_path_buf(), options: o.clone(), cartesian, lattice })
    }

    /// The Cartesian pyramid's levels (x, y, z), finest first: what each
    /// level is made from.
    pub fn cartesian_levels(&self) -> &[[usize; 3]] {
        &self.cartesian
    }

    /// The samples each level holds (x, y, z): the Cartesian levels, or
    /// their lattice boxes.
    pub fn levels(&self) -> Vec<[usize; 3]> {
        match &self.lattice {
            Some(l) => l.layout.dims.clone(),
            None => self.cartesian.clone(),
        }
    }

    /// The lattice the store's samples are on (None: Cartesian).
    pub fn lattice(&self) -> Option<&Lattice> {
        self.lattice.as_ref().map(|l| &l.lattice)
    }

    /// The period of the stored grid (1 for a Cartesian store, 2 for BCC/FCC cosets).
    pub fn period(&self) -> [usize; 3] {
        self.lattice.as_ref().map_or([1; 3], |l| l.layout.period)
    }

    /// A write unit's edge in stored (coset) samples: the shard, or the chunk.
    pub fn unit(&self) -> usize {
        self.options.shard.unwrap_or(self.options.chunk)
    }

    /// The stored array's shape (x, y, z) of level `k` (each coset channel's, for a lattice store).
    pub fn array_shape(&self, k: usize) -> [usize; 3] {
        match &self.lattice {
            Some(l) => l.layout.coset_shape(l.layout.dims[k]),
            None => self.cartesian[k],
        }
    }

    /// The low corners (stored samples, x, y, z) of level `k`'s write units, z slowest.
    pub fn unit_boxes(&self, k: usize) -> impl Iterator<Item = [usize; 3]> {
        super::write::unit_boxes(self.array_shape(k), self.unit())
    }

    /// The samples box (x, y, z; lattice or Cartesian samples) that the
    /// unit at `lo` of level `k` stores: its origin and size.
    pub fn unit_samples_box(&self, k: usize, lo: [usize; 3]) -> ([usize; 3], [usize; 3]) {
        let (p, unit, dims) = (self.period(), self.unit(), self.levels()[k]);
        let first: [usize; 3] = std::array::from_fn(|a| p[a] * lo[a]);
        let end: [usize; 3] = std::array::from_fn(|a| (p[a] * (lo[a] + unit)).min(dims[a]));
        (first, std::array::from_fn(|a| end[a] - first[a]))
    }

    fn write_error(&self, e: &dyn std::fmt::Display) -> VolumeError {
        ZarrError::Write { path: self.out.clone(), reason: e.to_string() }.into()
    }

    fn store(&self) -> Result<Arc<FilesystemStore>, VolumeError> {
        Ok(Arc::new(FilesystemStore::new(&self.out).map_err(|e| self.write_error(&e))?))
    }

    fn channels(&self) -> Option<usize> {
        self.lattice.as_ref().and_then(|l| (l.layout.cosets.len() > 1).then_some(l.layout.cosets.len()))
    }

    /// Makes the output folder (it must not exist, or be empty).
    pub fn make_folder(&self) -> Result<(), VolumeError> {
        let out = &self.out;
        if out.exists() && std::fs::read_dir(out).map(|mut d| d.next().is_some()).unwrap_or(true) {
            return Err(ZarrError::Exists { path: out.clone() }.into());
        }
        std::fs::create_dir_all(out).map_err(|e| self.write_error(&e))
    }

    /// Writes every level's array metadata (no chunk yet: unwritten
    /// chunks read as the fill value, 0).
    pub fn create(&self) -> Result<(), VolumeError> {
        let store = self.store()?;
        for k in 0..self.cartesian.len() {
            create_array(&store, k, self.array_shape(k), self.channels(), &self.options)
                .map_err(|e| self.write_error(&e))?;
        }
        Ok(())
    }

    /// Level `k`'s array, its shards' chunks laid out in C order: zarrs
    /// encodes a shard's chunks in parallel and by default lays them out
    /// as they finish, so the same data would give different bytes.
    fn array(&self, k: usize) -> Result<Array<FilesystemStore>, VolumeError> {
        let array = Array::open(self.store()?, &format!("/{k}")).map_err(|e| self.write_error(&e))?;
        let ordered = CodecSpecificOptions::default()
            .with_option(ShardingCodecOptions::default().with_subchunk_write_order(SubchunkWriteOrder::C));
        Ok(array.with_codec_specific_options(&ordered))
    }

    /// Writes the unit at `lo` (stored samples) of level `k` from `samples`
    /// (the level's samples: Cartesian, or on the lattice in the embedded
    /// layout), read over [`StorePlan::unit_samples_box`].
    pub fn write_unit(&self, k: usize, samples: &dyn BrickSource, lo: [usize; 3]) -> Result<(), VolumeError> {
        let shape = self.array_shape(k);
        let unit = self.unit();
        if k >= self.cartesian.len() || (0..3).any(|a| !lo[a].is_multiple_of(unit) || lo[a] >= shape[a]) {
            return Err(VolumeError::BadDims {
                dims: lo,
                reason: format!("no write unit of level {k} starts there (units of {unit} over {shape:?}, x, y, z)"),
            });
        }
        let hi: [usize; 3] = std::array::from_fn(|a| (lo[a] + unit).min(shape[a]) - 1);
        let (first, size) = self.unit_samples_box(k, lo);
        let mut box_values = vec![0f32; size.iter().product()];
        samples.read_box(first.map(|x| x as i64), size, &mut box_values)?;
        let values = match &self.lattice {
            Some(l) => coset_values(&box_values, &l.layout, l.layout.dims[k], first, size, lo, hi),
            None => box_values,
        };
        let mut ranges: Vec<std::ops::Range<u64>> = self.channels().map(|c| 0..c as u64).into_iter().collect();
        ranges.extend([2, 1, 0].map(|a| lo[a] as u64..hi[a] as u64 + 1));
        let ty = self.options.ty;
        store_values(&self.array(k)?, &ArraySubset::new_with_ranges(&ranges), &values, ty)
            .map_err(|e| self.write_error(&e))
    }

    /// Writes the unit whose samples box starts at `origin` (x, y, z) from
    /// `data`, exactly that box (`size`, x fastest): what one writer of
    /// many holds.
    pub fn write_block(&self, k: usize, data: &[f32], origin: [usize; 3], size: [usize; 3]) -> Result<(), VolumeError> {
        let p = self.period();
        let unit = self.unit();
        let levels = self.levels();
        let Some(&dims) = levels.get(k) else {
            return Err(VolumeError::BadDims {
                dims: origin,
                reason: format!("level {k}: the store has {} levels", levels.len()),
            });
        };
        let lo: [usize; 3] = std::array::from_fn(|a| origin[a] / p[a]);
        let aligned = (0..3).all(|a| origin[a].is_multiple_of(p[a] * unit) && origin[a] < dims[a]);
        if !aligned || self.unit_samples_box(k, lo) != (origin, size) {
            return Err(VolumeError::BadDims {
                dims: size,
                reason: format!(
                    "a block at {origin:?} (x, y, z) is not a write unit of level {k}: blocks start at multiples of \
                     {:?} and hold that many samples (fewer at the far edges)",
                    std::array::from_fn::<usize, 3, _>(|a| p[a] * unit)
                ),
            });
        }
        let lattice = match self.lattice() {
            Some(l) => l.clone(),
            None => Lattice::builtin("cc").map_err(|e| self.write_error(&e))?,
        };
        let window = Window::new(data, origin, size, dims, &lattice)?;
        self.write_unit(k, &window, lo)
    }

    /// Where the store is written.
    pub fn path(&self) -> &Path {
        &self.out
    }

    /// A lattice store's Cartesian pass: the float32 pyramid (same chunks,
    /// levels and reduction) in a hidden folder of the output, which each
    /// lattice level is resampled from and which [`StorePlan::remove_cartesian_pass`]
    /// removes at the end. None for a Cartesian store (its levels are reduced
    /// from its own stored levels).
    pub fn cartesian_pass(&self) -> Option<StorePlan> {
        self.lattice.as_ref().map(|_| StorePlan {
            out: self.out.join(CARTESIAN_PASS),
            options: PyramidOptions { ty: ZarrType::F32, ..self.options.clone() },
            cartesian: self.cartesian.clone(),
            lattice: None,
        })
    }

    /// Removes the Cartesian pass (a lattice store is complete without it).
    pub fn remove_cartesian_pass(&self) -> Result<(), VolumeError> {
        match self.cartesian_pass() {
            Some(pass) if pass.out.exists() => std::fs::remove_dir_all(&pass.out).map_err(|e| self.write_error(&e)),
            _ => Ok(()),
        }
    }

    /// Writes the unit at `lo` of Cartesian level `k` >= 1, reduced from
    /// level k - 1 as this store holds it (its footprint read back, integer
    /// samples as rounded): what [`write_pyramid`](super::write_pyramid) does unit by unit.
    pub fn write_reduced_unit(&self, k: usize, lo: [usize; 3]) -> Result<(), VolumeError> {
        if self.lattice.is_some() || k == 0 || k >= self.cartesian.len() {
            return Err(VolumeError::BadDims {
                dims: lo,
                reason: format!("level {k} of this store is not reduced from a level before it"),
            });
        }
        let fine = StoredLevel {
            out: &self.out,
            array: open_level(&self.out, k - 1)?,
            dims: self.cartesian[k - 1],
            o: &self.options,
        };
        self.write_unit(k, &Reduced { fine: &fine, dims: self.cartesian[k], reduction: self.options.reduction }, lo)
    }

    /// Calls `f` with lattice level `k`'s samples, made box by box from
    /// Cartesian level k of `image` (the finished Cartesian pass):
    /// resampled on the lattice and, with `prefilter`, prefiltered.
    pub fn with_lattice_samples(
        &self,
        image: &OmeZarr,
        k: usize,
        prefilter: Option<&Derivation>,
        f: &mut dyn FnMut(&dyn BrickSource) -> Result<(), VolumeError>,
    ) -> Result<(), VolumeError> {
        let Some(l) = &self.lattice else {
            return Err(VolumeError::BadDims {
                dims: [0; 3],
                reason: "a Cartesian store has no lattice levels".into(),
            });
        };
        if prefilter.map(|d| &d.filter.name) != l.layout.prefilter.as_ref() {
            return Err(VolumeError::BadDims {
                dims: [0; 3],
                reason: format!(
                    "the store is planned with prefilter {:?}, not {:?}",
                    l.layout.prefilter,
                    prefilter.map(|d| &d.filter.name)
                ),
            });
        }
        let cc = Lattice::builtin("cc").map_err(|e| self.write_error(&e))?;
        let level = ZarrVolume::new(image, Selection { level: k, ..Selection::default() }, &cc)?;
        let resampled;
        let on_lattice: &dyn BrickSource = if l.lattice.det() == 1 {
            &level
        } else {
            resampled = Resampled::new(&level, &l.lattice)?;
            &resampled
        };
        match prefilter {
            Some(d) => f(&Prefiltered::new(on_lattice, d)?),
            None => f(on_lattice),
        }
    }

    /// Writes the unit at `lo` of lattice level `k` from the finished
    /// Cartesian pass: one writer's share of
    /// [`write_lattice_pyramid`](super::write_lattice_pyramid).
    pub fn write_lattice_unit(
        &self,
        k: usize,
        lo: [usize; 3],
        prefilter: Option<&Derivation>,
    ) -> Result<(), VolumeError> {
        let pass = self.cartesian_pass().ok_or_else(|| VolumeError::BadDims {
            dims: lo,
            reason: "a Cartesian store has no lattice levels".into(),
        })?;
        let image = OmeZarr::open(&pass.out)?;
        self.with_lattice_samples(&image, k, prefilter, &mut |samples| self.write_unit(k, samples, lo))
    }

    /// Writes the group's metadata (OME-Zarr 0.5 multiscales, and for a
    /// lattice store the `boxforge` layout attribute): the store is complete.
    pub fn finish(&self) -> Result<PyramidReport, VolumeError> {
        let store = self.store()?;
        match &self.lattice {
            Some(l) => {
                super::cosets::write_lattice_group(&store, &l.layout, &l.matched, self.channels(), &self.options)
                    .map_err(|e| self.write_error(&e))?;
            }
            None => write_group(&store, &self.cartesian, &self.options).map_err(|e| self.write_error(&e))?,
        }
        Ok(PyramidReport { levels: self.levels() })
    }

    /// The reduction between Cartesian levels.
    pub fn reduction(&self) -> Reduction {
        self.options.reduction
    }
}

/// The coset grid box [lo, hi] (inclusive, x fastest) of every channel,
/// channel slowest, from the lattice samples `box_values` of the box at
/// `first` of `size`.
fn coset_values(
    box_values: &[f32],
    layout: &LatticeLayout,
    dims: [usize; 3],
    first: [usize; 3],
    size: [usize; 3],
    lo: [usize; 3],
    hi: [usize; 3],
) -> Vec<f32> {
    let p = layout.period;
    let count: [usize; 3] = std::array::from_fn(|a| hi[a] - lo[a] + 1);
    let mut values = Vec::with_capacity(layout.cosets.len() * count.iter().product::<usize>());
    for r in &layout.cosets {
        for z in lo[2]..=hi[2] {
            for y in lo[1]..=hi[1] {
                for x in lo[0]..=hi[0] {
                    let q = [p[0] * x + r[0], p[1] * y + r[1], p[2] * z + r[2]];
                    values.push(if (0..3).all(|a| q[a] < dims[a]) {
                        let b: [usize; 3] = std::array::from_fn(|a| q[a] - first[a]);
                        box_values[b[0] + size[0] * (b[1] + size[1] * b[2])]
                    } else {
                        0.0
                    });
                }
            }
        }
    }
    values
}
