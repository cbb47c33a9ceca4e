//! Lattice samples made from other samples box by box, so a volume larger
//! than memory can be resampled and prefiltered in pieces (`convert
//! --lattice/--prefilter` writes them chunk by chunk): [`Resampled`], a
//! Cartesian source resampled on a lattice at a matched sample count, and
//! [`Prefiltered`], a lattice source convolved with a filter's
//! quasi-interpolation prefilter. Each box reads only its footprint (the
//! box, plus one voxel for trilinear interpolation or the taps' reach) from
//! the source beneath, and every value is computed exactly as the
//! whole-volume functions compute it ([`LatticeVolume::resample`] through
//! [`matched_lattice`], [`crate::prefilter::prefilter_cpu`]), so a volume
//! made in pieces equals the one made whole, bit for bit, seams included.

use super::convert::Membership;
use super::source::check_box_len;
use super::{BrickSource, VolumeError};
use boxforge::derive::Derivation;
use boxforge::spec::lattice::Lattice;
use std::sync::OnceLock;

/// The lattice box a Cartesian volume of `dims` is resampled on at a
/// matched sample count (about as many lattice points as voxels), and the
/// scale s that puts lattice point j at Cartesian position j s: the box is
/// `dims` times |det G|^(1/3), rounded (at least 2), and s maps the x
/// extents onto each other. A Cartesian lattice keeps the grid (scale 1).
pub fn matched_lattice(lattice: &Lattice, dims: [usize; 3]) -> ([usize; 3], f64) {
    if lattice.det() == 1 {
        return (dims, 1.0);
    }
    let f = (lattice.det() as f64).cbrt();
    let out = dims.map(|n| ((n as f64 * f).round() as usize).max(2));
    let scale = (dims[0] as f64 - 1.0) / (out[0] as f64 - 1.0);
    (out, scale)
}

/// The clamped index range [first, last] of the box [lo, lo + size) in a
/// box of `dims` (every axis non-empty).
fn clamped(lo: [i64; 3], size: [usize; 3], dims: [usize; 3]) -> ([usize; 3], [usize; 3]) {
    let c = |v: i64, n: usize| v.clamp(0, n as i64 - 1) as usize;
    let first = std::array::from_fn(|a| c(lo[a], dims[a]));
    let last = std::array::from_fn(|a| c(lo[a].saturating_add(size[a] as i64 - 1), dims[a]));
    (first, last)
}

/// Calls `f(out_index, clamped_point)` for every texel of the box
/// [lo, lo + size), x fastest, the point clamped into `dims`.
fn for_each_clamped(lo: [i64; 3], size: [usize; 3], dims: [usize; 3], mut f: impl FnMut(usize, [usize; 3])) {
    let c = |v: i64, n: usize| v.clamp(0, n as i64 - 1) as usize;
    let mut i = 0;
    for dz in 0..size[2] {
        let z = c(lo[2].saturating_add(dz as i64), dims[2]);
        for dy in 0..size[1] {
            let y = c(lo[1].saturating_add(dy as i64), dims[1]);
            for dx in 0..size[0] {
                f(i, [c(lo[0].saturating_add(dx as i64), dims[0]), y, z]);
                i += 1;
            }
        }
    }
}

/// One pass over a source in z-slabs of whole planes, keeping (min, max)
/// of the values at lattice points.
pub(super) fn scan_range(source: &dyn BrickSource, member: &Membership) -> Result<(f32, f32), VolumeError> {
    let d = source.dims();
    let slab = (1usize << 22).div_ceil(d[0] * d[1]).clamp(1, d[2]);
    let (mut lo, mut hi) = (f32::INFINITY, f32::NEG_INFINITY);
    let mut buf = Vec::new();
    for z0 in (0..d[2]).step_by(slab) {
        let n = slab.min(d[2] - z0);
        buf.resize(d[0] * d[1] * n, 0.0);
        source.read_box([0, 0, z0 as i64], [d[0], d[1], n], &mut buf)?;
        for (k, &v) in buf.iter().enumerate() {
            let j = [k % d[0], (k / d[0]) % d[1], z0 + k / (d[0] * d[1])];
            if member.contains(j) {
                lo = lo.min(v);
                hi = hi.max(v);
            }
        }
    }
    Ok(if lo <= hi { (lo, hi) } else { (0.0, 0.0) })
}

/// [`scan_range`] once, the answer kept in `memo`.
pub(super) fn remembered_range(
    memo: &OnceLock<(f32, f32)>,
    source: &dyn BrickSource,
    member: &Membership,
) -> Result<(f32, f32), VolumeError> {
    if let Some(&r) = memo.get() {
        return Ok(r);
    }
    let r = scan_range(source, member)?;
    Ok(*memo.get_or_init(|| r))
}

/// A box of samples in memory standing for a larger volume: the samples
/// at [origin, origin + size) of a volume of `dims` on `lattice` (x
/// fastest), read clamped into the volume and then into the box. A chunk
/// with its halo passed in by a scheduler (Dask) reads as the whole volume
/// does wherever the halo covers the taps, so [`Resampled`] and
/// [`Prefiltered`] over it give the whole volume's values inside the
/// chunk; outside what the halo covers the values are not the volume's.
pub struct Window<'a> {
    data: &'a [f32],
    origin: [usize; 3],
    size: [usize; 3],
    dims: [usize; 3],
    lattice: Lattice,
}

impl<'a> Window<'a> {
    /// `data` (x fastest, `size` samples) at `origin` of a volume of `dims`.
    pub fn new(
        data: &'a [f32],
        origin: [usize; 3],
        size: [usize; 3],
        dims: [usize; 3],
        lattice: &Lattice,
    ) -> Result<Window<'a>, VolumeError> {
        check_box_len(size, data.len())?;
        super::error::checked_count(dims)?;
        if size.contains(&0) || (0..3).any(|a| origin[a].saturating_add(size[a]) > dims[a]) {
            return Err(VolumeError::BadDims {
                dims: size,
                reason: format!("a box of these dims at {origin:?} (x, y, z) does not fit in a volume of {dims:?}"),
            });
        }
        Ok(Window { data, origin, size, dims, lattice: lattice.clone() })
    }
}

impl BrickSource for Window<'_> {
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
        let (o, s) = (self.origin, self.size);
        for_each_clamped(lo, size, self.dims, |i, j| {
            let q: [usize; 3] = std::array::from_fn(|a| j[a].clamp(o[a], o[a] + s[a] - 1) - o[a]);
            out[i] = self.data[q[0] + s[0] * (q[1] + s[1] * q[2])];
        });
        Ok(())
    }

    fn sample_range(&self) -> Result<(f32, f32), VolumeError> {
        let member = Membership::new(&self.lattice)?;
        scan_range(self, &member)
    }

    fn resident_bytes(&self) -> usize {
        0
    }
}

/// A Cartesian source resampled on `lattice` at a matched sample count
/// ([`matched_lattice`]), by trilinear interpolation clamped to the
/// Cartesian grid: the values [`LatticeVolume::resample`] gives for the
/// whole volume, read box by box.
///
/// [`LatticeVolume::resample`]: super::LatticeVolume::resample
pub struct Resampled<'a> {
    cartesian: &'a dyn BrickSource,
    lattice: Lattice,
    member: Membership,
    dims: [usize; 3],
    scale: f64,
    range: OnceLock<(f32, f32)>,
}

impl<'a> Resampled<'a> {
    /// `cartesian` (a source on Z^3) on `lattice`.
    pub fn new(cartesian: &'a dyn BrickSource, lattice: &Lattice) -> Result<Resampled<'a>, VolumeError> {
        if cartesian.lattice().det() != 1 {
            return Err(VolumeError::BadDims {
                dims: cartesian.dims(),
                reason: format!(
                    "resampling reads Cartesian samples, and these are on the {} lattice",
                    cartesian.lattice().name
                ),
            });
        }
        let (dims, scale) = matched_lattice(lattice, cartesian.dims());
        super::error::checked_count(dims)?;
        Ok(Resampled {
            cartesian,
            lattice: lattice.clone(),
            member: Membership::new(lattice)?,
            dims,
            scale,
            range: OnceLock::new(),
        })
    }

    /// Lattice point j sits at Cartesian position j times this.
    pub fn scale(&self) -> f64 {
        self.scale
    }
}

/// Per axis of a trilinear lookup at `x` in a grid of `n`: the lower
/// corner and the weight of the upper one, as `Volume::trilinear` takes them.
fn trilinear_axis(x: f64, n: usize) -> (i64, f64) {
    let n = n.max(1) as f64;
    let x = if x.is_nan() { 0.0 } else { x.clamp(0.0, n - 1.0) };
    let i0 = x.floor().min((n - 2.0).max(0.0));
    (i0 as i64, x - i0)
}

impl BrickSource for Resampled<'_> {
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
        let n = self.cartesian.dims();
        let (first, last) = clamped(lo, size, self.dims);
        // The Cartesian footprint: the lower corners of the first and last
        // points, and one voxel past the last.
        let c0: [i64; 3] = std::array::from_fn(|a| trilinear_axis(first[a] as f64 * self.scale, n[a]).0);
        let c1: [i64; 3] = std::array::from_fn(|a| trilinear_axis(last[a] as f64 * self.scale, n[a]).0 + 1);
        let csize: [usize; 3] = std::array::from_fn(|a| (c1[a] - c0[a] + 1) as usize);
        let mut cart = vec![0f32; csize.iter().product()];
        self.cartesian.read_box(c0, csize, &mut cart)?;
        let at = |p: [i64; 3]| {
            let q: [usize; 3] = std::array::from_fn(|a| (p[a] - c0[a]) as usize);
            cart[q[0] + csize[0] * (q[1] + csize[1] * q[2])]
        };
        for_each_clamped(lo, size, self.dims, |i, j| {
            out[i] = if self.member.contains(j) {
                let axes: [(i64, f64); 3] = std::array::from_fn(|a| trilinear_axis(j[a] as f64 * self.scale, n[a]));
                let mut acc = 0.0f64;
                for corner in 0..8 {
                    let o = [(corner & 1) as i64, ((corner >> 1) & 1) as i64, ((corner >> 2) & 1) as i64];
                    let w: f64 = (0..3).map(|a| if o[a] == 1 { axes[a].1 } else { 1.0 - axes[a].1 }).product();
                    if w != 0.0 {
                        acc += w * at(std::array::from_fn(|a| axes[a].0 + o[a])) as f64;
                    }
                }
                acc as f32
            } else {
                0.0
            };
        });
        Ok(())
    }

    fn sample_range(&self) -> Result<(f32, f32), VolumeError> {
        remembered_range(&self.range, self, &self.member)
    }

    fn resident_bytes(&self) -> usize {
        self.cartesian.resident_bytes()
    }
}

/// A lattice source convolved with a filter's quasi-interpolation
/// prefilter: c_j = sum_k q_k f(j - k) at each lattice point, the samples
/// read clamped into the box (what [`crate::prefilter::prefilter_cpu`] and
/// the emitted prefilter kernel compute).
pub struct Prefiltered<'a> {
    inner: &'a dyn BrickSource,
    taps: Vec<([i64; 3], f64)>,
    reach: [usize; 3],
    member: Membership,
    range: OnceLock<(f32, f32)>,
}

impl<'a> Prefiltered<'a> {
    /// `inner` prefiltered for the derivation's filter, whose lattice it must be on.
    pub fn new(inner: &'a dyn BrickSource, d: &Derivation) -> Result<Prefiltered<'a>, VolumeError> {
        if d.filter.lattice.name != inner.lattice().name || d.facts.dim != 3 {
            return Err(VolumeError::LatticeMismatch {
                filter: d.filter.name.clone(),
                filter_lattice: d.filter.lattice.name.clone(),
                data_lattice: inner.lattice().name.clone(),
            });
        }
        let taps: Vec<([i64; 3], f64)> =
            d.prefilter.taps.iter().map(|(k, w)| ([k[0], k[1], k[2]], w.to_f64())).collect();
        let reach = std::array::from_fn(|a| taps.iter().map(|(k, _)| k[a].unsigned_abs() as usize).max().unwrap_or(0));
        Ok(Prefiltered { inner, taps, reach, member: Membership::new(inner.lattice())?, range: OnceLock::new() })
    }
}

impl BrickSource for Prefiltered<'_> {
    fn dims(&self) -> [usize; 3] {
        self.inner.dims()
    }

    fn lattice(&self) -> &Lattice {
        self.inner.lattice()
    }

    fn read_box(&self, lo: [i64; 3], size: [usize; 3], out: &mut [f32]) -> Result<(), VolumeError> {
        check_box_len(size, out.len())?;
        if out.is_empty() {
            return Ok(());
        }
        let dims = self.inner.dims();
        let (first, last) = clamped(lo, size, dims);
        let f0: [i64; 3] = std::array::from_fn(|a| first[a] as i64 - self.reach[a] as i64);
        let fsize: [usize; 3] = std::array::from_fn(|a| last[a] - first[a] + 1 + 2 * self.reach[a]);
        let mut values = vec![0f32; fsize.iter().product()];
        self.inner.read_box(f0, fsize, &mut values)?;
        let at = |p: [i64; 3]| {
            let q: [usize; 3] = std::array::from_fn(|a| (p[a] - f0[a]) as usize);
            values[q[0] + fsize[0] * (q[1] + fsize[1] * q[2])]
        };
        for_each_clamped(lo, size, dims, |i, j| {
            out[i] = if self.member.contains(j) {
                let j = j.map(|x| x as i64);
                self.taps.iter().map(|(k, w)| w * at([j[0] - k[0], j[1] - k[1], j[2] - k[2]]) as f64).sum::<f64>()
                    as f32
            } else {
                0.0
            };
        });
        Ok(())
    }

    fn sample_range(&self) -> Result<(f32, f32), VolumeError> {
        remembered_range(&self.range, self, &self.member)
    }

    fn resident_bytes(&self) -> usize {
        self.inner.resident_bytes()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::volume::testutil::{lattice, test_volume};
    use crate::volume::LatticeVolume;

    /// Reads `source` in boxes of `edge` (some past the ends) and checks
    /// each texel against `whole`.
    fn same_in_boxes(source: &dyn BrickSource, whole: &LatticeVolume, edge: usize) {
        let d = whole.dims;
        assert_eq!(source.dims(), d);
        for z in (-1..d[2] as i64 + 1).step_by(edge) {
            for y in (-2..d[1] as i64).step_by(edge) {
                for x in (0..d[0] as i64 + 2).step_by(edge) {
                    let size = [edge, edge + 1, edge];
                    let mut a = vec![0f32; size.iter().product()];
                    let mut b = a.clone();
                    source.read_box([x, y, z], size, &mut a).unwrap();
                    whole.read_box([x, y, z], size, &mut b).unwrap();
                    let bits = |v: &[f32]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
                    assert_eq!(bits(&a), bits(&b), "box at {:?}", [x, y, z]);
                }
            }
        }
    }

    #[test]
    fn resampling_box_by_box_equals_resampling_the_whole_volume() {
        let vol = test_volume([9, 8, 7]);
        let cart = LatticeVolume::subset(&lattice("cc"), &vol).unwrap();
        for name in ["bcc", "fcc"] {
            let l = lattice(name);
            let r = Resampled::new(&cart, &l).unwrap();
            let (dims, scale) = matched_lattice(&l, vol.dims);
            let whole = LatticeVolume::resample(&l, &vol, dims, scale).unwrap();
            same_in_boxes(&r, &whole, 3);
            same_in_boxes(&r, &whole, 5);
            assert_eq!(r.sample_range().unwrap(), whole.sample_range(), "{name}");
        }
        // A lattice source is not resampled again.
        let bcc = LatticeVolume::subset(&lattice("bcc"), &vol).unwrap();
        assert!(Resampled::new(&bcc, &lattice("fcc")).is_err());
    }

    #[test]
    fn a_chunk_with_its_halo_prefilters_and_resamples_as_the_whole_volume_inside_it() {
        let d = Derivation::new(&boxforge::spec::resolve("bcc7").unwrap()).unwrap();
        let vol = test_volume([11, 10, 9]);
        let cart = LatticeVolume::subset(&lattice("cc"), &vol).unwrap();
        let l = lattice("bcc");
        let whole = Resampled::new(&cart, &l).unwrap();
        let n = whole.dims();
        let mut all = vec![0f32; n.iter().product()];
        whole.read_box([0, 0, 0], n, &mut all).unwrap();
        let lat = LatticeVolume { lattice: l.clone(), dims: n, data: all.clone() };
        let pre = crate::prefilter::prefilter_cpu(&d, &lat);
        // An odd chunk at an odd origin, with a halo of 2 (bcc7's taps reach 2).
        let (lo, size, halo) = ([3usize, 5, 1], [5usize, 4, 7], 2usize);
        let h0: [usize; 3] = std::array::from_fn(|a| lo[a].saturating_sub(halo));
        let h1: [usize; 3] = std::array::from_fn(|a| (lo[a] + size[a] + halo).min(n[a]));
        let hs: [usize; 3] = std::array::from_fn(|a| h1[a] - h0[a]);
        let mut block = vec![0f32; hs.iter().product()];
        lat.read_box(h0.map(|x| x as i64), hs, &mut block).unwrap();
        let w = Window::new(&block, h0, hs, n, &l).unwrap();
        let p = Prefiltered::new(&w, &d).unwrap();
        let mut got = vec![0f32; size.iter().product()];
        p.read_box(lo.map(|x| x as i64), size, &mut got).unwrap();
        let mut want = vec![0f32; got.len()];
        pre.read_box(lo.map(|x| x as i64), size, &mut want).unwrap();
        assert_eq!(bits(&got), bits(&want));
        assert!(Window::new(&block, [9, 9, 9], hs, n, &l).is_err(), "a box past the volume");
    }

    fn bits(v: &[f32]) -> Vec<u32> {
        v.iter().map(|x| x.to_bits()).collect()
    }

    #[test]
    fn prefiltering_box_by_box_equals_prefiltering_the_whole_volume() {
        for (name, filter) in [("bcc", "bcc7"), ("fcc", "fcc6"), ("cc", "cc_tricubic")] {
            let d = Derivation::new(&boxforge::spec::resolve(filter).unwrap()).unwrap();
            let v = crate::volume::testutil::ramp_volume(name, [10, 9, 8]);
            let p = Prefiltered::new(&v, &d).unwrap();
            let whole = crate::prefilter::prefilter_cpu(&d, &v);
            same_in_boxes(&p, &whole, 4);
            assert_eq!(p.sample_range().unwrap(), whole.sample_range(), "{filter}");
        }
        let d = Derivation::new(&boxforge::spec::resolve("bcc7").unwrap()).unwrap();
        let fcc = crate::volume::testutil::ramp_volume("fcc", [6, 6, 6]);
        assert!(Prefiltered::new(&fcc, &d).is_err(), "a bcc prefilter on fcc samples");
    }
}
