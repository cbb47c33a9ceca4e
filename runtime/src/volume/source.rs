//! Where the bricked renderers read samples from, one box at a time: a
//! volume in memory ([`LatticeVolume`]) or a file read lazily (memory-mapped
//! raw and NIfTI files, `volume/stream.rs`), so a volume larger than host
//! memory is never read whole.

use super::{LatticeVolume, VolumeError};
use boxforge::spec::lattice::Lattice;

/// Lattice samples read box by box.
pub trait BrickSource: Sync {
    /// Box size (nx, ny, nz) in Z^3 of the embedded lattice volume.
    fn dims(&self) -> [usize; 3];

    /// The data lattice.
    fn lattice(&self) -> &Lattice;

    /// Writes the texels j in [lo, lo + size) (x fastest) into `out`: each
    /// the sample at j clamped into the box, 0 at non-lattice points (as the
    /// embedded layout's clamped fetch reads them). `out.len()` is the
    /// product of `size`.
    fn read_box(&self, lo: [i64; 3], size: [usize; 3], out: &mut [f32]) -> Result<(), VolumeError>;

    /// (min, max) of the samples at lattice points ((0, 0) when none). May
    /// read the whole source once; implementations remember the answer.
    fn sample_range(&self) -> Result<(f32, f32), VolumeError>;

    /// Bytes of host memory the source holds beyond what the OS maps (for
    /// the memory bound the out-of-core renderer states).
    fn resident_bytes(&self) -> usize;

    /// A text that changes whenever the samples may have changed (a file's
    /// path, length and modification time, and how it is read), for caches
    /// of what is derived from the samples; None: not cacheable.
    fn identity(&self) -> Option<String> {
        None
    }
}

impl BrickSource for LatticeVolume {
    fn dims(&self) -> [usize; 3] {
        self.dims
    }

    fn lattice(&self) -> &Lattice {
        &self.lattice
    }

    fn read_box(&self, lo: [i64; 3], size: [usize; 3], out: &mut [f32]) -> Result<(), VolumeError> {
        check_box_len(size, out.len())?;
        let mut i = 0;
        for z in 0..size[2] as i64 {
            for y in 0..size[1] as i64 {
                for x in 0..size[0] as i64 {
                    out[i] = self.get(&[lo[0] + x, lo[1] + y, lo[2] + z]);
                    i += 1;
                }
            }
        }
        Ok(())
    }

    fn sample_range(&self) -> Result<(f32, f32), VolumeError> {
        Ok(LatticeVolume::sample_range(self))
    }

    fn resident_bytes(&self) -> usize {
        self.data.len() * 4
    }
}

/// Refuses an output slice whose length is not the box's texel count.
pub fn check_box_len(size: [usize; 3], len: usize) -> Result<(), VolumeError> {
    let n = size.iter().try_fold(1usize, |a, &s| a.checked_mul(s));
    if n != Some(len) {
        return Err(VolumeError::BadDims {
            dims: size,
            reason: format!("a box of these dims needs {n:?} texels, the buffer holds {len}"),
        });
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::volume::testutil::ramp_volume;

    #[test]
    fn an_in_memory_box_reads_the_clamped_samples() {
        let v = ramp_volume("bcc", [6, 5, 4]);
        let mut out = vec![0f32; 3 * 3 * 3];
        v.read_box([-1, 3, 2], [3, 3, 3], &mut out).unwrap();
        let mut i = 0;
        for z in 2..5 {
            for y in 3..6 {
                for x in -1..2 {
                    assert_eq!(out[i], v.get(&[x, y, z]));
                    i += 1;
                }
            }
        }
        assert!(v.read_box([0, 0, 0], [2, 2, 2], &mut out).is_err(), "a buffer of the wrong length");
    }
}
