//! Test helpers shared by the volume modules' unit tests: catalog lattices,
//! self-removing temp files, the MNI head path and independent lattice
//! membership rules.

use super::Volume;
use boxforge::spec::lattice::Lattice;
use std::path::{Path, PathBuf};

/// A built-in lattice by name.
pub(super) fn lattice(name: &str) -> Lattice {
    Lattice::builtin(name).unwrap()
}

/// A unique temp path, removed on drop.
pub(super) struct Temp(pub(super) PathBuf);
impl Temp {
    pub(super) fn new(name: &str, bytes: &[u8]) -> Temp {
        let p = std::env::temp_dir().join(format!("boxforge-volume-{}-{name}", std::process::id()));
        std::fs::write(&p, bytes).unwrap();
        Temp(p)
    }
}
impl Drop for Temp {
    fn drop(&mut self) {
        let _ = std::fs::remove_file(&self.0);
    }
}

/// The MNI152 head (data/mni152_t1_1mm.nii.gz).
pub(super) fn mni_path() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../data/mni152_t1_1mm.nii.gz")
}

/// Independent membership rules of docs/BOX_SPLINES.md §1.
pub(super) fn member(name: &str, j: [usize; 3]) -> bool {
    match name {
        "cc" => true,
        "bcc" => j[0] % 2 == j[1] % 2 && j[1] % 2 == j[2] % 2,
        "fcc" => (j[0] + j[1] + j[2]).is_multiple_of(2),
        _ => unreachable!(),
    }
}

/// Lattice points in a box, by formula: BCC = all-even + all-odd points;
/// FCC = (N + s_x s_y s_z) / 2 with s = #even - #odd = n mod 2 per axis.
pub(super) fn expected_samples(name: &str, d: [usize; 3]) -> usize {
    match name {
        "cc" => d[0] * d[1] * d[2],
        "bcc" => d.map(|n| n.div_ceil(2)).iter().product::<usize>() + d.map(|n| n / 2).iter().product::<usize>(),
        "fcc" => (d[0] * d[1] * d[2] + d.map(|n| n % 2).iter().product::<usize>()) / 2,
        _ => unreachable!(),
    }
}

/// A volume of distinct non-zero values 1, 2, 3, ... (x fastest).
pub(super) fn test_volume(dims: [usize; 3]) -> Volume {
    let n = dims[0] * dims[1] * dims[2];
    Volume::new(dims, (0..n).map(|i| 1.0 + i as f32).collect()).unwrap()
}

/// A lattice volume of `dims` on lattice `name` whose samples all differ
/// (a ramp over the texel index at lattice points, 0 elsewhere).
pub(super) fn ramp_volume(name: &str, dims: [usize; 3]) -> super::LatticeVolume {
    let lattice = lattice(name);
    let mut data = vec![0f32; dims[0] * dims[1] * dims[2]];
    for z in 0..dims[2] {
        for y in 0..dims[1] {
            for x in 0..dims[0] {
                let i = x + dims[0] * (y + dims[1] * z);
                if lattice.contains(&[x as i64, y as i64, z as i64]) {
                    data[i] = 1.0 + i as f32;
                }
            }
        }
    }
    super::LatticeVolume { lattice, dims, data }
}
