//! Samples of a 4D lattice (space and time) and their device form: WGSL has
//! no 4D textures (and no 3D texture arrays), so a 4D module reads its
//! samples from one read-only storage buffer, `<f>_samples`, as
//! templates/fetch_storage.wgsl.j2 lays it out: a `vec4<i32>` header, then the
//! f32 samples x fastest, then y, z and w.
//!
//! Why a buffer: stacking time slices along z meets the 2048-texel limit at
//! 64^3 x 32, and several textures would need a branch or a binding per
//! slice. A buffer holds any 4D extent up to the adapter's storage binding
//! size (128 MiB by default, asked for up to the adapter's limit), with one
//! index computation per fetch and no branch.

use super::error::checked_count;
use super::VolumeError;
use crate::gpu::binding::storage_entry;
use crate::gpu::Gpu;
use boxforge::emit::{coset_of, coset_pivots, Layout};
use boxforge::spec::lattice::Lattice;

/// Samples of a 4D lattice over a box of integer points (x, y, z, w), w
/// slowest; 0 at the points that are not lattice points.
#[derive(Clone, Debug, PartialEq)]
pub struct LatticeVolume4 {
    /// The data lattice (4D), embedded in Z^4.
    pub lattice: Lattice,
    /// Box size (nx, ny, nz, nw) in Z^4.
    pub dims: [usize; 4],
    /// Embedded samples, x fastest, 0 at non-lattice points.
    pub data: Vec<f32>,
}

fn index(dims: [usize; 4], j: [usize; 4]) -> usize {
    j[0] + dims[0] * (j[1] + dims[1] * (j[2] + dims[2] * j[3]))
}

impl LatticeVolume4 {
    /// A volume from its parts; errors on a lattice that is not 4D, an
    /// empty box or a data length that does not match the dims.
    pub fn new(lattice: Lattice, dims: [usize; 4], data: Vec<f32>) -> Result<LatticeVolume4, VolumeError> {
        if lattice.dim() != 4 {
            return Err(VolumeError::LatticeDim { lattice: lattice.name.clone(), dim: lattice.dim() });
        }
        let expected = checked_count([dims[0], dims[1], dims[2]])?
            .checked_mul(dims[3])
            .filter(|&n| n > 0 && n <= i32::MAX as usize)
            .ok_or(VolumeError::FourDBox { dims })?;
        if data.len() != expected {
            return Err(VolumeError::FourDLength { dims, len: data.len(), expected });
        }
        Ok(LatticeVolume4 { lattice, dims, data })
    }

    /// A Cartesian time series as samples of Z^4: frame k at w = k.
    pub fn from_series(series: &super::VolumeSeries) -> LatticeVolume4 {
        let lattice = Lattice::builtin("z4").expect("z4 is built in");
        LatticeVolume4 { lattice, dims: series.dims, data: series.data.clone() }
    }

    /// Samples of `lattice` over a box of `dims` from `value` at each
    /// lattice point (0 elsewhere), computed on every core.
    pub fn from_fn(
        lattice: &Lattice,
        dims: [usize; 4],
        value: impl Fn([usize; 4]) -> f32 + Sync,
    ) -> Result<LatticeVolume4, VolumeError> {
        let n: usize = dims.iter().product();
        let mut data = vec![0f32; n];
        let threads = std::thread::available_parallelism().map_or(1, |t| t.get());
        let per = n.div_ceil(threads).max(1);
        std::thread::scope(|s| {
            for (c, chunk) in data.chunks_mut(per).enumerate() {
                let value = &value;
                s.spawn(move || {
                    for (o, v) in chunk.iter_mut().enumerate() {
                        let i = c * per + o;
                        let j = [
                            i % dims[0],
                            (i / dims[0]) % dims[1],
                            (i / (dims[0] * dims[1])) % dims[2],
                            i / (dims[0] * dims[1] * dims[2]),
                        ];
                        if lattice.contains(&j.map(|x| x as i64)) {
                            *v = value(j);
                        }
                    }
                });
            }
        });
        LatticeVolume4::new(lattice.clone(), dims, data)
    }

    /// The lattice subset of a Cartesian series (the samples at lattice
    /// points, 1/det of them): lattice units are the series' voxels and frames.
    pub fn subset(lattice: &Lattice, series: &super::VolumeSeries) -> Result<LatticeVolume4, VolumeError> {
        let d = series.dims;
        LatticeVolume4::from_fn(lattice, d, |j| series.data[index(d, j)])
    }

    /// The box of `lattice` with as many samples per unit of space-time as
    /// Z^4 has over `dims` (each axis times det^(1/4)).
    pub fn matched_dims(lattice: &Lattice, dims: [usize; 4]) -> [usize; 4] {
        let f = (lattice.det().unsigned_abs() as f64).powf(0.25);
        dims.map(|n| ((n as f64 * f).round() as usize).max(2))
    }

    /// A Cartesian series resampled on `lattice` at a matched sample count
    /// ([`LatticeVolume4::matched_dims`]) by quadrilinear interpolation;
    /// also returns the lattice units per frame of the series.
    pub fn resample(lattice: &Lattice, series: &super::VolumeSeries) -> Result<(LatticeVolume4, f64), VolumeError> {
        let d = series.dims;
        let dims = LatticeVolume4::matched_dims(lattice, d);
        let scale: [f64; 4] = std::array::from_fn(|a| (d[a] as f64 - 1.0).max(0.0) / (dims[a] as f64 - 1.0));
        let at = |x: [f64; 4]| -> f32 {
            let mut acc = 0.0f64;
            let base: [usize; 4] = std::array::from_fn(|a| (x[a].floor() as usize).min(d[a].saturating_sub(2)));
            let frac: [f64; 4] = std::array::from_fn(|a| if d[a] > 1 { x[a] - base[a] as f64 } else { 0.0 });
            for corner in 0..16usize {
                let mut w = 1.0;
                let mut j = [0usize; 4];
                for a in 0..4 {
                    let bit = corner >> a & 1;
                    w *= if bit == 1 { frac[a] } else { 1.0 - frac[a] };
                    j[a] = (base[a] + bit).min(d[a] - 1);
                }
                if w != 0.0 {
                    acc += w * series.data[index(d, j)] as f64;
                }
            }
            acc as f32
        };
        let vol = LatticeVolume4::from_fn(lattice, dims, |j| at(std::array::from_fn(|a| j[a] as f64 * scale[a])))?;
        Ok((vol, 1.0 / scale[3]))
    }

    /// The drifting Marschner-Lobb signal sampled directly on `lattice` at
    /// the count of `n`^3 x `frames` Cartesian samples (space [-1, 1]^3,
    /// time [0, 1]); also returns the lattice units per frame of that series.
    pub fn marschner_lobb_drift(
        lattice: &Lattice,
        n: usize,
        frames: usize,
    ) -> Result<(LatticeVolume4, f64), VolumeError> {
        let dims = LatticeVolume4::matched_dims(lattice, [n, n, n, frames]);
        let at = |j: usize, m: usize| j as f64 / (m - 1) as f64;
        let vol = LatticeVolume4::from_fn(lattice, dims, |j| {
            super::marschner_lobb_drift([
                -1.0 + 2.0 * at(j[0], dims[0]),
                -1.0 + 2.0 * at(j[1], dims[1]),
                -1.0 + 2.0 * at(j[2], dims[2]),
                at(j[3], dims[3]),
            ]) as f32
        })?;
        Ok((vol, (dims[3] - 1) as f64 / (frames.max(2) - 1) as f64))
    }

    /// Sample at integer position `j` (4 entries), clamped to the box, as
    /// the emitted clamped fetch reads it.
    pub fn get(&self, j: &[i64]) -> f32 {
        let c = |a: usize| j.get(a).copied().unwrap_or(0).clamp(0, self.dims[a] as i64 - 1) as usize;
        self.data.get(index(self.dims, [c(0), c(1), c(2), c(3)])).copied().unwrap_or(0.0)
    }

    /// The buffer of the embedded layout: the header (the box size) and
    /// every point of the box.
    pub fn embedded_words(&self) -> Vec<u32> {
        let mut w: Vec<u32> = self.dims.iter().map(|&n| n as u32).collect();
        w.extend(self.data.iter().map(|v| v.to_bits()));
        w
    }

    /// The buffer of the packed layout: the header (one coset's grid g =
    /// ceil(dims / 2)) and the coset grids tiled in an array of (1 + p) g
    /// words per axis (p = 1 on the pivot axes): sample j of the coset with
    /// parity vector r at element (j >> 1) + (r & p) g, x fastest. With an
    /// odd dim, the slot past the box holds the same coset's point two steps
    /// back, so the clamped fetch replicates each coset's boundary.
    pub fn packed_words(&self) -> Result<Vec<u32>, VolumeError> {
        let err = |message: String| VolumeError::Packed { lattice: self.lattice.name.clone(), message };
        let pivots = coset_pivots(&self.lattice).map_err(|e| err(e.to_string()))?;
        let g = self.dims.map(|n| n.div_ceil(2));
        let e: [usize; 4] = std::array::from_fn(|a| if pivots.contains(&a) { 2 * g[a] } else { g[a] });
        let mut parity: Vec<Option<[i64; 4]>> = vec![None; 1 << pivots.len()];
        for bits in 0..16usize {
            let r: [i64; 4] = std::array::from_fn(|a| ((bits >> a) & 1) as i64);
            if self.lattice.contains(&r) {
                parity[coset_of(&pivots, &r)].get_or_insert(r);
            }
        }
        let mut buf = vec![0f32; e.iter().product()];
        for r in parity.iter().flatten() {
            let o: [usize; 4] = std::array::from_fn(|a| if pivots.contains(&a) { r[a] as usize * g[a] } else { 0 });
            for mw in 0..g[3] {
                for mz in 0..g[2] {
                    for my in 0..g[1] {
                        for mx in 0..g[0] {
                            let m = [mx, my, mz, mw];
                            let j: Option<[usize; 4]> = (0..4)
                                .map(|a| {
                                    let v = 2 * m[a] + r[a] as usize;
                                    if v < self.dims[a] {
                                        Some(v)
                                    } else {
                                        v.checked_sub(2)
                                    }
                                })
                                .collect::<Option<Vec<usize>>>()
                                .map(|v| [v[0], v[1], v[2], v[3]]);
                            if let Some(j) = j {
                                let t: [usize; 4] = std::array::from_fn(|a| m[a] + o[a]);
                                buf[index(e, t)] = self.data[index(self.dims, j)];
                            }
                        }
                    }
                }
            }
        }
        let mut w: Vec<u32> = g.iter().map(|&n| n as u32).collect();
        w.extend(buf.iter().map(|v| v.to_bits()));
        Ok(w)
    }
}

/// Refuses `bytes` of 4D samples over the storage binding `limit`, naming
/// both sizes and what to do.
pub fn check_fits(bytes: usize, limit: usize, layout: Layout) -> Result<(), VolumeError> {
    if bytes <= limit {
        return Ok(());
    }
    Err(VolumeError::FourDTooLarge { bytes, limit, layout: layout.name() })
}

/// A 4D volume on the device: the one storage buffer of `<f>_samples`.
pub struct DeviceVolume4 {
    pub layout: Layout,
    buffer: wgpu::Buffer,
    /// Bytes on the device.
    pub bytes: usize,
}

impl DeviceVolume4 {
    /// Uploads `vol` in `layout` (embedded or packed).
    ///
    /// # Errors
    ///
    /// [`VolumeError`] for a bricked layout, a lattice without a packed
    /// layout, or a buffer past the adapter's storage binding size (with
    /// the sizes and what to do).
    pub fn new(gpu: &Gpu, vol: &LatticeVolume4, layout: Layout) -> Result<DeviceVolume4, VolumeError> {
        let words = match layout {
            Layout::Embedded => vol.embedded_words(),
            Layout::Packed => vol.packed_words()?,
            other => return Err(VolumeError::FourDLayout { layout: other.name() }),
        };
        let bytes = 4 * words.len();
        check_fits(bytes, gpu.device.limits().max_storage_buffer_binding_size as usize, layout)?;
        let buffer = gpu.storage_buffer("4d samples", bytemuck::cast_slice(&words), false);
        Ok(DeviceVolume4 { layout, buffer, bytes })
    }

    /// The layout entry of the samples at `binding` (compute stage).
    pub fn layout_entry(&self, binding: u32) -> wgpu::BindGroupLayoutEntry {
        storage_entry(binding, true)
    }

    /// The bind group entry of the samples at `binding`.
    pub fn bind_entry(&self, binding: u32) -> wgpu::BindGroupEntry<'_> {
        wgpu::BindGroupEntry { binding, resource: self.buffer.as_entire_binding() }
    }

    /// The samples as a bind group of their own (binding 0, the emitted
    /// module's `<f>_samples`) and its layout: group 0 of every 4D pipeline.
    pub fn group(&self, gpu: &Gpu) -> Result<(wgpu::BindGroupLayout, wgpu::BindGroup), crate::gpu::GpuError> {
        let dev = &gpu.device;
        let layout = dev.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("4d samples"),
            entries: &[self.layout_entry(0)],
        });
        let group = gpu.checked("bind the 4D samples", || {
            dev.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("4d samples"),
                layout: &layout,
                entries: &[self.bind_entry(0)],
            })
        })?;
        Ok((layout, group))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn vol(name: &str, dims: [usize; 4]) -> LatticeVolume4 {
        let lattice = Lattice::builtin(name).unwrap();
        let n: usize = dims.iter().product();
        let data = (0..n)
            .map(|i| {
                let j = [i % dims[0], (i / dims[0]) % dims[1], (i / (dims[0] * dims[1])) % dims[2], i / (n / dims[3])];
                if lattice.contains(&j.map(|x| x as i64)) {
                    1.0 + i as f32
                } else {
                    0.0
                }
            })
            .collect();
        LatticeVolume4::new(lattice, dims, data).unwrap()
    }

    /// The shader's packed fetch, in Rust: every lattice point of the box is
    /// read back from the tiled buffer with the template's arithmetic.
    #[test]
    fn packed_words_hold_every_lattice_point_where_the_fetch_reads() {
        for (name, dims) in
            [("d4star", [6, 4, 4, 6]), ("d4", [4, 6, 4, 4]), ("z4", [4, 4, 2, 4]), ("d4star", [5, 4, 3, 4])]
        {
            let v = vol(name, dims);
            let w = v.packed_words().unwrap();
            let g: [i64; 4] = std::array::from_fn(|a| w[a] as i64);
            let piv = coset_pivots(&v.lattice).unwrap();
            let mask: [i64; 4] = std::array::from_fn(|a| i64::from(piv.contains(&a)));
            let e: [i64; 4] = std::array::from_fn(|a| g[a] + mask[a] * g[a]);
            assert_eq!(w.len() - 4, e.iter().product::<i64>() as usize, "{name}");
            let mut seen = 0;
            for i in 0..v.data.len() {
                let j = [
                    i % dims[0],
                    (i / dims[0]) % dims[1],
                    (i / (dims[0] * dims[1])) % dims[2],
                    i / (v.data.len() / dims[3]),
                ]
                .map(|x| x as i64);
                if !v.lattice.contains(&j) {
                    continue;
                }
                let t: [i64; 4] = std::array::from_fn(|a| (j[a] >> 1) + (j[a] & mask[a]) * g[a]);
                let k = t[0] + e[0] * (t[1] + e[1] * (t[2] + e[2] * t[3]));
                assert_eq!(f32::from_bits(w[4 + k as usize]), v.get(&j), "{name} at {j:?}");
                seen += 1;
            }
            let det = v.lattice.det() as usize;
            assert!(seen * det >= v.data.len() / 2, "{name}: {seen} lattice points");
        }
    }

    #[test]
    fn embedded_words_are_the_header_and_the_box() {
        let v = vol("d4star", [4, 4, 4, 2]);
        let w = v.embedded_words();
        assert_eq!(&w[..4], &[4, 4, 4, 2]);
        assert_eq!(w.len(), 4 + 128);
        assert_eq!(f32::from_bits(w[4 + 1 + 4 + 16 + 64]), v.get(&[1, 1, 1, 1]));
    }

    /// Quadrilinear resampling reproduces a function linear in each
    /// coordinate at the scaled lattice points; the subset keeps the lattice
    /// points' samples.
    #[test]
    fn resample_and_subset_of_a_series() {
        let dims = [6, 5, 4, 5];
        let f = |x: [f64; 4]| 0.5 + 0.1 * x[0] - 0.2 * x[1] + 0.05 * x[2] + 0.3 * x[3];
        let data: Vec<f32> = (0..dims.iter().product())
            .map(|i: usize| {
                let j = [i % 6, (i / 6) % 5, (i / 30) % 4, i / 120];
                f(j.map(|x| x as f64)) as f32
            })
            .collect();
        let series = crate::volume::VolumeSeries::new(dims, data).unwrap();
        let d4s = Lattice::builtin("d4star").unwrap();
        let (r, per_frame) = LatticeVolume4::resample(&d4s, &series).unwrap();
        assert_eq!(r.dims, LatticeVolume4::matched_dims(&d4s, dims));
        assert!((per_frame - (r.dims[3] - 1) as f64 / 4.0).abs() < 1e-12);
        let scale: [f64; 4] = std::array::from_fn(|a| (dims[a] - 1) as f64 / (r.dims[a] - 1) as f64);
        for (i, v) in r.data.iter().enumerate() {
            let n = r.dims;
            let j = [i % n[0], (i / n[0]) % n[1], (i / (n[0] * n[1])) % n[2], i / (n[0] * n[1] * n[2])];
            if d4s.contains(&j.map(|x| x as i64)) {
                let want = f(std::array::from_fn(|a| j[a] as f64 * scale[a]));
                assert!((*v as f64 - want).abs() < 1e-5, "at {j:?}: {v} vs {want}");
            } else {
                assert_eq!(*v, 0.0);
            }
        }
        let s = LatticeVolume4::subset(&d4s, &series).unwrap();
        assert_eq!(s.get(&[1, 1, 1, 1]), series.data[1 + 6 * (1 + 5 * (1 + 4))]);
        assert_eq!(s.get(&[1, 0, 0, 0]), 0.0);
    }

    #[test]
    fn a_volume_past_the_binding_limit_is_refused_with_the_estimate() {
        assert!(check_fits(128 << 20, 128 << 20, Layout::Packed).is_ok());
        let e = check_fits((128 << 20) + 1, 128 << 20, Layout::Embedded).unwrap_err().to_string();
        assert!(
            e.contains("129 MiB") && e.contains("128 MiB") && e.contains("packed layout") && !e.contains('\n'),
            "{e}"
        );
        let e = check_fits(300 << 20, 128 << 20, Layout::Packed).unwrap_err().to_string();
        assert!(e.contains("300 MiB") && !e.contains("or the packed layout"), "{e}");
    }

    #[test]
    fn bad_volumes_are_refused() {
        let l = Lattice::builtin("d4star").unwrap();
        assert!(LatticeVolume4::new(l.clone(), [2, 2, 2, 2], vec![0.0; 15]).is_err());
        assert!(LatticeVolume4::new(l, [2, 2, 0, 2], vec![]).is_err());
        let bcc = Lattice::builtin("bcc").unwrap();
        assert!(matches!(
            LatticeVolume4::new(bcc, [2, 2, 2, 2], vec![0.0; 16]),
            Err(VolumeError::LatticeDim { dim: 3, .. })
        ));
    }
}
