//! Lattice sample sets from Cartesian data: lattice membership in a box,
//! filling a box at the lattice points, the lattice subset of a Cartesian
//! volume and its trilinear resampling on a scaled lattice.

use super::error::checked_count;
use super::{LatticeVolume, Volume, VolumeError};
use boxforge::spec::lattice::Lattice;

/// Lattice membership in a box, through one period of the lattice: p_i e_i is
/// in L for the per-axis periods p_i (which divide |det G|), so membership of j
/// only depends on j mod p.
pub(super) struct Membership {
    period: [usize; 3],
    table: Vec<bool>,
}

impl Membership {
    pub(super) fn new(lattice: &Lattice) -> Result<Membership, VolumeError> {
        if lattice.dim() != 3 {
            return Err(VolumeError::LatticeDim { lattice: lattice.name.clone(), dim: lattice.dim() });
        }
        let det = lattice.det().max(1);
        let mut period = [1usize; 3];
        for (a, p) in period.iter_mut().enumerate() {
            let mut e = [0i64; 3];
            *p = (1..=det)
                .find(|&k| {
                    e[a] = k;
                    lattice.contains(&e)
                })
                .unwrap_or(det) as usize;
        }
        let size = period[0].saturating_mul(period[1]).saturating_mul(period[2]);
        if size > 1 << 24 {
            return Err(VolumeError::Packed {
                lattice: lattice.name.clone(),
                message: format!(
                    "its period box {period:?} is too large for a volume; use a lattice with a smaller determinant"
                ),
            });
        }
        let mut table = vec![false; size];
        for (idx, t) in table.iter_mut().enumerate() {
            let j = [
                (idx % period[0]) as i64,
                ((idx / period[0]) % period[1]) as i64,
                (idx / (period[0] * period[1])) as i64,
            ];
            *t = lattice.contains(&j);
        }
        Ok(Membership { period, table })
    }

    /// Bytes of the table (one bool per residue class).
    #[cfg(feature = "files")]
    pub(super) fn table_bytes(&self) -> usize {
        self.table.len()
    }

    /// The per-axis periods (x, y, z).
    #[cfg(feature = "zarr")]
    pub(super) fn period(&self) -> [usize; 3] {
        self.period
    }

    /// The residues mod the period that are lattice points (x fastest):
    /// the lattice's cosets of the period grid.
    #[cfg(feature = "zarr")]
    pub(super) fn residues(&self) -> Vec<[usize; 3]> {
        let p = self.period;
        (0..self.table.len())
            .filter(|&idx| self.table[idx])
            .map(|idx| [idx % p[0], (idx / p[0]) % p[1], idx / (p[0] * p[1])])
            .collect()
    }

    pub(super) fn contains(&self, j: [usize; 3]) -> bool {
        let p = self.period;
        self.table[j[0] % p[0] + p[0] * ((j[1] % p[1]) + p[1] * (j[2] % p[2]))]
    }

    /// Lattice points in [0, dims): per residue class, the product of per-axis counts.
    fn count(&self, dims: [usize; 3]) -> usize {
        let p = self.period;
        let per_axis = |r: usize, a: usize| if r < dims[a] { (dims[a] - r).div_ceil(p[a]) } else { 0 };
        let mut n = 0;
        for (idx, &t) in self.table.iter().enumerate() {
            if t {
                let r = [idx % p[0], (idx / p[0]) % p[1], idx / (p[0] * p[1])];
                n += per_axis(r[0], 0) * per_axis(r[1], 1) * per_axis(r[2], 2);
            }
        }
        n
    }
}

impl LatticeVolume {
    /// Fill a box by evaluating `f` at every lattice point (0 elsewhere).
    pub(super) fn from_fn(
        lattice: &Lattice,
        dims: [usize; 3],
        mut f: impl FnMut([usize; 3]) -> f32,
    ) -> Result<LatticeVolume, VolumeError> {
        let count = checked_count(dims)?;
        let member = Membership::new(lattice)?;
        let mut data = vec![0f32; count];
        let mut idx = 0;
        for k in 0..dims[2] {
            for j in 0..dims[1] {
                for i in 0..dims[0] {
                    if member.contains([i, j, k]) {
                        data[idx] = f([i, j, k]);
                    }
                    idx += 1;
                }
            }
        }
        Ok(LatticeVolume { lattice: lattice.clone(), dims, data })
    }

    /// Number of lattice points in the box (0 if the lattice is not 3-D).
    pub fn samples(&self) -> usize {
        Membership::new(&self.lattice).map(|m| m.count(self.dims)).unwrap_or(0)
    }

    /// The lattice subset of a Cartesian volume (as the literature makes BCC/FCC data): keep values at lattice points.
    pub fn subset(lattice: &Lattice, vol: &Volume) -> Result<LatticeVolume, VolumeError> {
        let expected = checked_count(vol.dims)?;
        if vol.data.len() != expected {
            return Err(VolumeError::DataLength { dims: vol.dims, len: vol.data.len(), expected });
        }
        let [nx, ny, _] = vol.dims;
        LatticeVolume::from_fn(lattice, vol.dims, |[i, j, k]| vol.data[i + nx * (j + ny * k)])
    }

    /// Resample a Cartesian volume at the lattice points of a grid scaled by `scale` (lattice
    /// point j -> Cartesian voxel position j * scale) with trilinear interpolation of the
    /// Cartesian data (clamped to the volume). A higher-quality resampling (a box-spline
    /// reconstruction of the Cartesian data through a filter, then sampling) can be layered
    /// on top later: only the per-point value function changes.
    pub fn resample(
        lattice: &Lattice,
        vol: &Volume,
        dims: [usize; 3],
        scale: f64,
    ) -> Result<LatticeVolume, VolumeError> {
        if !(scale.is_finite() && scale > 0.0) {
            return Err(VolumeError::BadScale { scale });
        }
        let expected = checked_count(vol.dims)?;
        if vol.data.len() != expected {
            return Err(VolumeError::DataLength { dims: vol.dims, len: vol.data.len(), expected });
        }
        LatticeVolume::from_fn(lattice, dims, |j| {
            vol.trilinear([j[0] as f64 * scale, j[1] as f64 * scale, j[2] as f64 * scale]) as f32
        })
    }
}

impl Volume {
    /// The volume box-averaged over `f`^3 blocks (a partial last block
    /// averages what it has): the MNI head at 2 or 4 mm for the bench and
    /// the browser viewer.
    pub fn downsample(&self, f: usize) -> Volume {
        let f = f.max(1);
        let dims = self.dims.map(|n| n.div_ceil(f));
        let mut data = Vec::with_capacity(dims.iter().product());
        for z in 0..dims[2] {
            for y in 0..dims[1] {
                for x in 0..dims[0] {
                    let (mut sum, mut n) = (0.0f64, 0usize);
                    for k in z * f..((z + 1) * f).min(self.dims[2]) {
                        for j in y * f..((y + 1) * f).min(self.dims[1]) {
                            for i in x * f..((x + 1) * f).min(self.dims[0]) {
                                sum += self.data[i + self.dims[0] * (j + self.dims[1] * k)] as f64;
                                n += 1;
                            }
                        }
                    }
                    data.push((sum / n as f64) as f32);
                }
            }
        }
        Volume { dims, data }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::volume::testutil::{expected_samples, lattice, member, test_volume};

    #[test]
    fn subset_keeps_exactly_the_lattice_points() {
        for name in ["cc", "bcc", "fcc"] {
            for dims in [[8, 8, 8], [7, 6, 5], [1, 1, 1], [9, 9, 9], [2, 3, 1]] {
                let vol = test_volume(dims);
                let l = LatticeVolume::subset(&lattice(name), &vol).unwrap();
                assert_eq!(l.dims, dims);
                let mut kept = 0;
                for k in 0..dims[2] {
                    for j in 0..dims[1] {
                        for i in 0..dims[0] {
                            let idx = i + dims[0] * (j + dims[1] * k);
                            if member(name, [i, j, k]) {
                                assert_eq!(l.data[idx], vol.data[idx]);
                                kept += 1;
                            } else {
                                assert_eq!(l.data[idx], 0.0, "{name} {:?}", [i, j, k]);
                            }
                        }
                    }
                }
                assert_eq!(kept, expected_samples(name, dims), "{name} {dims:?}");
                assert_eq!(l.samples(), kept, "{name} {dims:?}");
                assert_eq!(l.data.iter().filter(|&&x| x != 0.0).count(), kept);
            }
        }
        // n^3 BCC: about n^3 / 4.
        let l = LatticeVolume::subset(&lattice("bcc"), &test_volume([33, 33, 33])).unwrap();
        assert_eq!(l.samples(), 17 * 17 * 17 + 16 * 16 * 16);
        assert!((l.samples() as f64 / (33.0f64).powi(3) - 0.25).abs() < 0.03);
    }

    #[test]
    fn resample_is_trilinear_at_scaled_points() {
        // A linear function is reproduced exactly by trilinear interpolation.
        let dims = [9, 7, 5];
        let mut data = Vec::new();
        for k in 0..dims[2] {
            for j in 0..dims[1] {
                for i in 0..dims[0] {
                    data.push(1.0 + 0.5 * i as f32 - 0.25 * j as f32 + 2.0 * k as f32);
                }
            }
        }
        let vol = Volume::new(dims, data).unwrap();
        let f = |p: [f64; 3]| 1.0 + 0.5 * p[0] - 0.25 * p[1] + 2.0 * p[2];
        let scale = 0.7;
        let l = LatticeVolume::resample(&lattice("fcc"), &vol, [10, 8, 6], scale).unwrap();
        assert_eq!(l.samples(), expected_samples("fcc", [10, 8, 6]));
        for k in 0..6i64 {
            for j in 0..8i64 {
                for i in 0..10i64 {
                    let v = l.get(&[i, j, k]);
                    if member("fcc", [i as usize, j as usize, k as usize]) {
                        // Clamped to the Cartesian grid.
                        let p = [(i as f64 * scale).min(8.0), (j as f64 * scale).min(6.0), (k as f64 * scale).min(4.0)];
                        assert!((v as f64 - f(p)).abs() < 1e-4, "{i} {j} {k}: {v} vs {}", f(p));
                    } else {
                        assert_eq!(v, 0.0);
                    }
                }
            }
        }
        let e = LatticeVolume::resample(&lattice("fcc"), &vol, [4, 4, 4], f64::NAN).unwrap_err();
        assert!(matches!(e, VolumeError::BadScale { .. }), "{e}");
    }
}
