//! The pieces an OME-Zarr 0.5 pyramid (Zarr v3, zstd, optionally sharded)
//! is written with: its options, its arrays, a unit's values stored as the
//! sample type, the group metadata, and the reduction between levels. Each
//! coarser level is reduced from the level just written, one write unit (a
//! chunk, or a shard when sharded) at a time, reading back only the unit's
//! footprint (its box at twice the size plus the filter's reach), so host
//! memory stays at a few write units, whatever the volume (`pyramid.rs`,
//! `plan.rs`).
//!
//! **The reduction, chosen by measurement.** [`Reduction::Box`] (the
//! default) is the 2x2x2 mean, cell-centred: level k+1 has `floor(n / 2)`
//! samples, twice the scale and a translation of half a coarse voxel. Its
//! rivals, all vertex-aligned (sample i of level k+1 on sample 2i of level
//! k, `ceil(n / 2)` samples, no translation): [`Reduction::Subsample`]
//! (every second sample, no low-pass), [`Reduction::Tent`] ((1, 2, 1)/4,
//! the linear B-spline's two-scale step) and [`Reduction::Binomial`]
//! ((1, 4, 6, 4, 1)/16, the cubic B-spline's, Burt and Adelson's REDUCE).
//! `boxforge bench --pyramid` reconstructs every level of Marschner-Lobb
//! with the trilinear and tricubic B-splines against the analytic function
//! (docs/BENCHMARKS.md): while a level still resolves the signal,
//! subsampling loses least (it keeps the full amplitude) and the stronger
//! low-passes lose most (at the coarse Nyquist frequency the box keeps
//! cos(pi/4) = 0.71 of the amplitude, the tent 0.5, the binomial 0.25);
//! at the first level that no longer resolves it, subsampling aliases and
//! the box is best. Among the reductions that low-pass, which a pyramid
//! needs so its coarse levels do not alias, the box loses least at every
//! level. Integer samples are rounded to the nearest value the type holds.

use super::{ZarrError, ZarrType};
use crate::volume::{BrickSource, VolumeError};
use std::path::Path;
use std::sync::Arc;
use zarrs::array::{Array, ArrayBuilder, ArraySubset};
use zarrs::filesystem::FilesystemStore;

/// How each coarser level is made from the one before it.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Reduction {
    /// (1, 4, 6, 4, 1)/16 per axis, every second sample, vertex-aligned.
    Binomial,
    /// The mean of each 2x2x2 block, cell-centred (the default: see the module's doc).
    #[default]
    Box,
    /// Every second sample, no low-pass (aliases; kept to measure against).
    Subsample,
    /// (1, 2, 1)/4 per axis (the linear B-spline's two-scale step), every
    /// second sample, vertex-aligned.
    Tent,
}

impl Reduction {
    /// The name stored in the multiscales `type` field.
    pub fn name(self) -> &'static str {
        match self {
            Reduction::Binomial => "binomial",
            Reduction::Box => "box",
            Reduction::Subsample => "subsample",
            Reduction::Tent => "tent",
        }
    }

    /// Samples of the next level along an axis of `n`.
    pub fn next_len(self, n: usize) -> usize {
        match self {
            Reduction::Binomial | Reduction::Subsample | Reduction::Tent => n.div_ceil(2),
            Reduction::Box => (n / 2).max(1),
        }
    }
}

/// How [`write_pyramid`](super::write_pyramid) lays the store out.
#[derive(Clone, Debug)]
pub struct PyramidOptions {
    /// Chunk edge in samples (default 64).
    pub chunk: usize,
    /// Shard edge in samples (a multiple of `chunk`), or unsharded.
    pub shard: Option<usize>,
    /// Number of levels; None: until the largest edge fits one chunk.
    pub levels: Option<usize>,
    /// How coarser levels are made.
    pub reduction: Reduction,
    /// Stored sample type.
    pub ty: ZarrType,
    /// Physical voxel size of level 0 along (x, y, z).
    pub spacing: [f64; 3],
    /// The unit of `spacing` (a UDUNITS name: `millimeter`, `micrometer`,
    /// ...), written on the space axes; none: unitless.
    pub unit: Option<String>,
    /// zstd level of the chunks.
    pub zstd_level: i32,
}

impl Default for PyramidOptions {
    fn default() -> Self {
        PyramidOptions {
            chunk: 64,
            shard: None,
            levels: None,
            reduction: Reduction::Box,
            ty: ZarrType::F32,
            spacing: [1.0; 3],
            unit: None,
            zstd_level: 3,
        }
    }
}

/// What [`write_pyramid`](super::write_pyramid) wrote.
#[derive(Clone, Debug, PartialEq)]
pub struct PyramidReport {
    /// Each level's samples along (x, y, z), finest first.
    pub levels: Vec<[usize; 3]>,
}

pub(super) fn open_level(out: &Path, k: usize) -> Result<Array<FilesystemStore>, VolumeError> {
    let werr = |e: &dyn std::fmt::Display| {
        VolumeError::from(ZarrError::Write { path: out.to_path_buf(), reason: e.to_string() })
    };
    let store = Arc::new(FilesystemStore::new(out).map_err(|e| werr(&e))?);
    Array::open(store, &format!("/{k}")).map_err(|e| werr(&e))
}

pub(super) fn check_options(o: &PyramidOptions) -> Result<(), ZarrError> {
    if o.chunk == 0 || o.chunk > 1024 {
        return Err(ZarrError::Option {
            option: "chunk",
            value: o.chunk as u64,
            need: "give a chunk edge from 1 to 1024 (e.g. 64)",
        });
    }
    if let Some(s) = o.shard {
        if s == 0 || s % o.chunk != 0 || s > 4096 {
            return Err(ZarrError::Option {
                option: "shard",
                value: s as u64,
                need: "give a shard edge that is a multiple of the chunk edge, at most 4096",
            });
        }
    }
    if o.levels == Some(0) || o.levels.is_some_and(|n| n > 32) {
        return Err(ZarrError::Option {
            option: "levels",
            value: o.levels.unwrap_or(0) as u64,
            need: "give from 1 to 32 levels",
        });
    }
    Ok(())
}

/// The low corners of the write units covering `dims`, z slowest.
pub(super) fn unit_boxes(dims: [usize; 3], unit: usize) -> impl Iterator<Item = [usize; 3]> {
    (0..dims[2]).step_by(unit).flat_map(move |z| {
        (0..dims[1]).step_by(unit).flat_map(move |y| (0..dims[0]).step_by(unit).map(move |x| [x, y, z]))
    })
}

/// Level `level`'s array of `d` (x, y, z) samples, with a leading channel
/// axis of `channels` (a lattice store's cosets, each chunk holding all of
/// them) when given.
pub(super) fn create_array(
    store: &Arc<FilesystemStore>,
    level: usize,
    d: [usize; 3],
    channels: Option<usize>,
    o: &PyramidOptions,
) -> Result<Array<FilesystemStore>, Box<dyn std::error::Error>> {
    let lead: Vec<u64> = channels.map(|c| c as u64).into_iter().collect();
    let shape = [lead.clone(), vec![d[2] as u64, d[1] as u64, d[0] as u64]].concat();
    let chunk = o.chunk as u64;
    // A level smaller than a shard gets one shard of whole chunks.
    let largest = d.iter().copied().max().unwrap_or(1) as u64;
    let unit = o.shard.map_or(chunk, |s| (s as u64).min(largest.div_ceil(chunk) * chunk));
    let zstd: Arc<dyn zarrs::array::BytesToBytesCodecTraits> =
        Arc::new(zarrs::array::codec::ZstdCodec::new(o.zstd_level, false));
    let data_type = match o.ty {
        ZarrType::U8 => zarrs::array::data_type::uint8(),
        ZarrType::U16 => zarrs::array::data_type::uint16(),
        ZarrType::I16 => zarrs::array::data_type::int16(),
        ZarrType::F32 => zarrs::array::data_type::float32(),
    };
    let fill: zarrs::array::FillValue = match o.ty {
        ZarrType::U8 => 0u8.into(),
        ZarrType::U16 => 0u16.into(),
        ZarrType::I16 => 0i16.into(),
        ZarrType::F32 => 0f32.into(),
    };
    let edges = |e: u64| [lead.clone(), vec![e; 3]].concat();
    let mut b = if o.shard.is_some() {
        let mut b = ArrayBuilder::new(shape, edges(unit), data_type, fill);
        b.subchunk_shape(edges(chunk));
        b
    } else {
        ArrayBuilder::new(shape, edges(chunk), data_type, fill)
    };
    b.bytes_to_bytes_codecs(vec![zstd]);
    if channels.is_some() {
        b.dimension_names(Some(["c", "z", "y", "x"]));
    } else {
        b.dimension_names(Some(["z", "y", "x"]));
    }
    let array = b.build(store.clone(), &format!("/{level}"))?;
    array.store_metadata()?;
    Ok(array)
}

pub(super) fn store_values(
    array: &Array<FilesystemStore>,
    subset: &ArraySubset,
    v: &[f32],
    ty: ZarrType,
) -> Result<(), zarrs::array::ArrayError> {
    fn round<T>(v: &[f32], lo: f32, hi: f32, f: impl Fn(f32) -> T) -> Vec<T> {
        v.iter().map(|&x| f(x.round().clamp(lo, hi))).collect()
    }
    match ty {
        ZarrType::U8 => array.store_array_subset(subset, round(v, 0.0, 255.0, |x| x as u8)),
        ZarrType::U16 => array.store_array_subset(subset, round(v, 0.0, 65535.0, |x| x as u16)),
        ZarrType::I16 => array.store_array_subset(subset, round(v, -32768.0, 32767.0, |x| x as i16)),
        ZarrType::F32 => array.store_array_subset(subset, v.to_vec()),
    }
}

/// A level just written, read back box by box as float32.
pub(super) struct StoredLevel<'a> {
    pub(super) out: &'a Path,
    pub(super) array: Array<FilesystemStore>,
    pub(super) dims: [usize; 3],
    pub(super) o: &'a PyramidOptions,
}

impl StoredLevel<'_> {
    fn read(&self, f0: [usize; 3], f1: [usize; 3]) -> Result<Vec<f32>, VolumeError> {
        let subset = ArraySubset::new_with_ranges(&[
            f0[2] as u64..f1[2] as u64 + 1,
            f0[1] as u64..f1[1] as u64 + 1,
            f0[0] as u64..f1[0] as u64 + 1,
        ]);
        let rerr = |e: zarrs::array::ArrayError| {
            VolumeError::from(ZarrError::Read {
                path: self.out.to_path_buf(),
                level: "written level".into(),
                reason: e.to_string(),
            })
        };
        let fine = &self.array;
        Ok(match self.o.ty {
            ZarrType::U8 => {
                fine.retrieve_array_subset::<Vec<u8>>(&subset).map_err(rerr)?.into_iter().map(f32::from).collect()
            }
            ZarrType::U16 => {
                fine.retrieve_array_subset::<Vec<u16>>(&subset).map_err(rerr)?.into_iter().map(f32::from).collect()
            }
            ZarrType::I16 => {
                fine.retrieve_array_subset::<Vec<i16>>(&subset).map_err(rerr)?.into_iter().map(f32::from).collect()
            }
            ZarrType::F32 => fine.retrieve_array_subset::<Vec<f32>>(&subset).map_err(rerr)?,
        })
    }
}

/// The next level of a stored level, box by box: each box reads its footprint.
pub(super) struct Reduced<'a> {
    pub(super) fine: &'a StoredLevel<'a>,
    pub(super) dims: [usize; 3],
    pub(super) reduction: Reduction,
}

impl Reduced<'_> {
    fn read_inside(&self, lo: [usize; 3], size: [usize; 3]) -> Result<Vec<f32>, VolumeError> {
        let n = self.fine.dims;
        let hi: [usize; 3] = std::array::from_fn(|a| lo[a] + size[a] - 1);
        let (f0, f1) = self.reduction.footprint(n, lo, hi);
        let data = self.fine.read(f0, f1)?;
        let window: [usize; 3] = std::array::from_fn(|a| f1[a] - f0[a] + 1);
        self.reduction.reduce(&data, f0, window, n, lo, size)
    }
}

impl BrickSource for Reduced<'_> {
    fn dims(&self) -> [usize; 3] {
        self.dims
    }

    fn lattice(&self) -> &boxforge::spec::lattice::Lattice {
        static CC: std::sync::OnceLock<boxforge::spec::lattice::Lattice> = std::sync::OnceLock::new();
        CC.get_or_init(|| boxforge::spec::lattice::Lattice::builtin("cc").expect("cc is built in"))
    }

    fn read_box(&self, lo: [i64; 3], size: [usize; 3], out: &mut [f32]) -> Result<(), VolumeError> {
        // The writer reads whole units inside the level.
        let inside = (0..3).all(|a| lo[a] >= 0 && lo[a] as usize + size[a] <= self.dims[a]);
        if !inside || out.len() != size.iter().product::<usize>() {
            return Err(VolumeError::BadDims { dims: size, reason: format!("a box at {lo:?} outside the level") });
        }
        out.copy_from_slice(&self.read_inside(lo.map(|x| x as usize), size)?);
        Ok(())
    }

    fn sample_range(&self) -> Result<(f32, f32), VolumeError> {
        Err(VolumeError::BadDims { dims: self.dims, reason: "a level being written has no range yet".into() })
    }

    fn resident_bytes(&self) -> usize {
        0
    }
}

impl Reduction {
    /// How far the reduction's taps reach past sample 2i of the finer level.
    fn reach(self) -> (usize, usize) {
        match self {
            Reduction::Binomial => (2, 2),
            Reduction::Box => (0, 1),
            Reduction::Tent => (1, 1),
            Reduction::Subsample => (0, 0),
        }
    }

    /// The box [f0, f1] (inclusive, x, y, z) of a finer level of `n`
    /// samples that the coarser samples [lo, hi] read.
    pub fn footprint(self, n: [usize; 3], lo: [usize; 3], hi: [usize; 3]) -> ([usize; 3], [usize; 3]) {
        let (before, after) = self.reach();
        let f0 = std::array::from_fn(|a| (2 * lo[a]).saturating_sub(before).min(n[a] - 1));
        let f1 = std::array::from_fn(|a| (2 * hi[a] + after).min(n[a] - 1));
        (f0, f1)
    }

    /// The coarser level's samples in the box at `lo` of `count` (x
    /// fastest), from `data`: the finer level's samples (of `n`) in the box
    /// at `origin` of `size`, which must hold [`Reduction::footprint`].
    /// The same sums in the same order wherever the box is cut, so a level
    /// reduced in pieces equals the level reduced whole, bit for bit.
    pub fn reduce(
        self,
        data: &[f32],
        origin: [usize; 3],
        size: [usize; 3],
        n: [usize; 3],
        lo: [usize; 3],
        count: [usize; 3],
    ) -> Result<Vec<f32>, VolumeError> {
        let coarse = n.map(|x| self.next_len(x));
        if count.contains(&0) || (0..3).any(|a| lo[a] + count[a] > coarse[a]) {
            return Err(VolumeError::BadDims {
                dims: count,
                reason: format!("a box at {lo:?} (x, y, z) is not inside the reduced level of {coarse:?}"),
            });
        }
        let hi: [usize; 3] = std::array::from_fn(|a| lo[a] + count[a] - 1);
        let (f0, f1) = self.footprint(n, lo, hi);
        let covers = (0..3).all(|a| origin[a] <= f0[a] && f1[a] < origin[a] + size[a] && origin[a] + size[a] <= n[a]);
        if !covers || data.len() != size.iter().product::<usize>() {
            return Err(VolumeError::BadDims {
                dims: size,
                reason: format!(
                    "the samples at {origin:?} (x, y, z) do not cover the reduction's footprint {f0:?}..={f1:?}"
                ),
            });
        }
        let mut data = std::borrow::Cow::Borrowed(data);
        let mut size = size;
        for axis in 0..3 {
            let reduced = reduce_axis(
                &data,
                size,
                axis,
                count[axis],
                |j, t| {
                    let p = match self {
                        Reduction::Binomial | Reduction::Tent => mirror(2 * (lo[axis] + j) as i64 + t, n[axis]),
                        Reduction::Box | Reduction::Subsample => {
                            (2 * (lo[axis] + j) + t.max(0) as usize).min(n[axis] - 1)
                        }
                    };
                    p - origin[axis]
                },
                self,
            );
            data = std::borrow::Cow::Owned(reduced);
            size[axis] = count[axis];
        }
        Ok(data.into_owned())
    }
}

/// The index p of a sample reflected into [0, n) about the end samples.
fn mirror(p: i64, n: usize) -> usize {
    let last = n as i64 - 1;
    let q = if p < 0 {
        -p
    } else if p > last {
        2 * last - p
    } else {
        p
    };
    q.clamp(0, last) as usize
}

/// Filters `data` (of `size`, x fastest) along `axis` down to `count`
/// samples: output j is the weighted sum over taps t of the input at
/// `index(j, t)` (a position in the box).
fn reduce_axis(
    data: &[f32],
    size: [usize; 3],
    axis: usize,
    count: usize,
    index: impl Fn(usize, i64) -> usize,
    reduction: Reduction,
) -> Vec<f32> {
    const BINOMIAL: [(i64, f32); 5] = [(-2, 1.0), (-1, 4.0), (0, 6.0), (1, 4.0), (2, 1.0)];
    const BOX: [(i64, f32); 2] = [(0, 8.0), (1, 8.0)];
    const SUBSAMPLE: [(i64, f32); 1] = [(0, 16.0)];
    const TENT: [(i64, f32); 3] = [(-1, 4.0), (0, 8.0), (1, 4.0)];
    let taps: &[(i64, f32)] = match reduction {
        Reduction::Binomial => &BINOMIAL,
        Reduction::Box => &BOX,
        Reduction::Subsample => &SUBSAMPLE,
        Reduction::Tent => &TENT,
    };
    let mut out_size = size;
    out_size[axis] = count;
    let stride = [1, size[0], size[0] * size[1]];
    let mut out = vec![0f32; out_size.iter().product()];
    let positions: Vec<Vec<(usize, f32)>> =
        (0..count).map(|j| taps.iter().map(|&(t, w)| (index(j, t), w / 16.0)).collect()).collect();
    let mut i = 0;
    for z in 0..out_size[2] {
        for y in 0..out_size[1] {
            for x in 0..out_size[0] {
                let mut at = [x, y, z];
                let j = at[axis];
                let mut sum = 0f32;
                for &(p, w) in &positions[j] {
                    at[axis] = p;
                    sum += w * data[at[0] * stride[0] + at[1] * stride[1] + at[2] * stride[2]];
                }
                out[i] = sum;
                i += 1;
            }
        }
    }
    out
}

/// The group's `zarr.json` with the OME-Zarr 0.5 multiscales metadata.
pub(super) fn write_group(
    store: &Arc<FilesystemStore>,
    dims: &[[usize; 3]],
    o: &PyramidOptions,
) -> Result<(), Box<dyn std::error::Error>> {
    let s0 = [o.spacing[2], o.spacing[1], o.spacing[0]];
    let datasets: Vec<serde_json::Value> = (0..dims.len())
        .map(|k| {
            let f = (1u64 << k) as f64;
            let scale: Vec<f64> = s0.iter().map(|s| s * f).collect();
            let mut transforms = vec![serde_json::json!({"type": "scale", "scale": scale})];
            if o.reduction == Reduction::Box && k > 0 {
                let shift: Vec<f64> = s0.iter().map(|s| s * (f - 1.0) / 2.0).collect();
                transforms.push(serde_json::json!({"type": "translation", "translation": shift}));
            }
            serde_json::json!({"path": k.to_string(), "coordinateTransformations": transforms})
        })
        .collect();
    let axis = |name: &str| space_axis(name, o);
    let ome = serde_json::json!({
        "version": "0.5",
        "multiscales": [{
            "name": "boxforge",
            "axes": [axis("z"), axis("y"), axis("x")],
            "datasets": datasets,
            "type": o.reduction.name(),
            "metadata": {"method": "boxforge convert", "reduction": reduction_doc(o.reduction)},
        }],
    });
    let mut group = zarrs::group::GroupBuilder::new().build(store.clone(), "/")?;
    group.attributes_mut().insert("ome".into(), ome);
    group.store_metadata()?;
    Ok(())
}

/// A space axis of the multiscales metadata, with the options' unit.
pub(super) fn space_axis(name: &str, o: &PyramidOptions) -> serde_json::Value {
    match &o.unit {
        Some(unit) => serde_json::json!({"name": name, "type": "space", "unit": unit}),
        None => serde_json::json!({"name": name, "type": "space"}),
    }
}

fn reduction_doc(r: Reduction) -> &'static str {
    match r {
        Reduction::Binomial => {
            "(1,4,6,4,1)/16 per axis, every second sample, vertex-aligned (level k+1 sample i on level k sample 2i)"
        }
        Reduction::Box => "mean of each 2x2x2 block, cell-centred",
        Reduction::Subsample => "every second sample, no low-pass, vertex-aligned",
        Reduction::Tent => {
            "(1,2,1)/4 per axis, every second sample, vertex-aligned (level k+1 sample i on level k sample 2i)"
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_level_reduced_in_pieces_is_the_level_reduced_whole() {
        let n = [9, 7, 6];
        let data: Vec<f32> = (0..n.iter().product::<usize>()).map(|i| ((i * 37 % 101) as f32) * 0.37 - 3.1).collect();
        for r in [Reduction::Binomial, Reduction::Box, Reduction::Tent, Reduction::Subsample] {
            let m = n.map(|x| r.next_len(x));
            let whole = r.reduce(&data, [0; 3], n, n, [0; 3], m).unwrap();
            for (i, &w) in whole.iter().enumerate() {
                let lo = [i % m[0], (i / m[0]) % m[1], i / (m[0] * m[1])];
                let (f0, f1) = r.footprint(n, lo, lo);
                let size: [usize; 3] = std::array::from_fn(|a| f1[a] - f0[a] + 1);
                let mut window = vec![];
                for z in f0[2]..=f1[2] {
                    for y in f0[1]..=f1[1] {
                        for x in f0[0]..=f1[0] {
                            window.push(data[x + n[0] * (y + n[1] * z)]);
                        }
                    }
                }
                let piece = r.reduce(&window, f0, size, n, lo, [1; 3]).unwrap();
                assert_eq!(piece[0].to_bits(), w.to_bits(), "{r:?} at {lo:?}");
                if size.iter().product::<usize>() > 1 && r != Reduction::Subsample {
                    // A window short of the footprint is refused, never read past.
                    let short = [size[0] - usize::from(size[0] > 1), size[1], size[2]];
                    let cut = vec![0f32; short.iter().product()];
                    if short != size {
                        assert!(r.reduce(&cut, f0, short, n, lo, [1; 3]).is_err());
                    }
                }
            }
        }
    }

    #[test]
    fn mirror_reflects_about_the_end_samples() {
        assert_eq!([-2, -1, 0, 5, 6, 7].map(|p| mirror(p, 7)), [2, 1, 0, 5, 6, 5]);
        assert_eq!(mirror(-1, 1), 0);
    }

    #[test]
    fn binomial_keeps_linear_ramps_inside_and_constants_everywhere() {
        // A ramp along x: (1,4,6,4,1)/16 reproduces degree-1 polynomials away from the ends.
        let n = 11;
        let data: Vec<f32> = (0..n).map(|x| 3.0 * x as f32 + 1.0).collect();
        let out = reduce_axis(&data, [n, 1, 1], 0, 6, |j, t| mirror(2 * j as i64 + t, n), Reduction::Binomial);
        for (j, v) in out.iter().enumerate().take(5).skip(1) {
            assert!((v - (6.0 * j as f32 + 1.0)).abs() < 1e-5, "{j}: {v}");
        }
        let flat = vec![2.5f32; n];
        let out = reduce_axis(&flat, [n, 1, 1], 0, 6, |j, t| mirror(2 * j as i64 + t, n), Reduction::Binomial);
        assert!(out.iter().all(|v| (v - 2.5).abs() < 1e-6), "{out:?}");
    }
}
