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
            .ok_or_else(|| VolumeError::FourD {
                message: format!("a 4D box of {dims:?} points is empty or past i32 indexing: use a smaller box"),
            })?;
        if data.len() != expected {
            return Err(VolumeError::FourD {
                message: format!(
                    "{} values for a 4D box of {dims:?} need {expected}: build it with matching dims and data",
                    data.len()
                ),
            });
        }
        Ok(LatticeVolume4 { lattice, dims, data })
    }

    /// A Cartesian time series as samples of Z^4: frame k at w = k.
    pub fn from_series(series: &super::VolumeSeries) -> LatticeVolume4 {
        let lattice = Lattice::builtin("z4").expect("z4 is built in");
        LatticeVolume4 { lattice, dims: series.dims, data: series.data.clone() }
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
            other => {
                return Err(VolumeError::FourD {
                    message: format!(
                    "4D samples are a storage buffer: the {} layout is not offered; use --layout embedded or packed",
                    other.name()
                ),
                })
            }
        };
        let bytes = 4 * words.len();
        let limit = gpu.device.limits().max_storage_buffer_binding_size as usize;
        if bytes > limit {
            return Err(VolumeError::FourD {
                message: format!(
                    "the 4D samples need {} MiB in the {} layout, over this adapter's storage binding limit of {} MiB: \
                     use fewer frames or a smaller volume{}",
                    bytes >> 20,
                    layout.name(),
                    limit >> 20,
                    if layout == Layout::Embedded { ", or the packed layout (one word per sample)" } else { "" }
                ),
            });
        }
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
