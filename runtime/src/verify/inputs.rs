//! The random inputs of the device checks: a deterministic random source,
//! random samples on a filter's lattice and random points (and points on
//! brick faces) where the whole support lies inside the volume.

use crate::volume::{support_radius, LatticeVolume};
use boxforge::derive::Derivation;

/// A deterministic random source (SplitMix64).
pub struct Rng(pub u64);
impl Rng {
    pub fn next_f64(&mut self) -> f64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64
    }
}

/// Random data in [0, 1) at the lattice points of a box big enough for the support.
pub fn random_volume(d: &Derivation, seed: u64) -> LatticeVolume {
    let r = support_radius(d);
    let n = (2 * r + 10).next_multiple_of(2);
    let dims = [n, n, n];
    let mut rng = Rng(seed);
    let mut data = vec![0f32; n * n * n];
    for k in 0..n {
        for j in 0..n {
            for i in 0..n {
                if d.filter.lattice.contains(&[i as i64, j as i64, k as i64]) {
                    data[i + n * (j + n * k)] = rng.next_f64() as f32;
                }
            }
        }
    }
    LatticeVolume { lattice: d.filter.lattice.clone(), dims, data }
}

/// Random points where the whole support lies inside the volume.
pub fn random_points(d: &Derivation, vol: &LatticeVolume, count: usize, seed: u64) -> Vec<[f32; 4]> {
    let r = support_radius(d) as f64 + 1.0;
    let mut rng = Rng(seed ^ 0xABCD);
    (0..count)
        .map(|_| {
            let mut p = [0f32; 4];
            for (i, pi) in p.iter_mut().take(3).enumerate() {
                let n = vol.dims[i] as f64;
                *pi = (r + rng.next_f64() * (n - 1.0 - 2.0 * r)) as f32;
            }
            p
        })
        .collect()
}

/// Points on and a rounding error either side of brick faces (edge
/// `edge`): `base`'s points with one coordinate (cycling over the axes)
/// moved to the nearest face inside the volume's interior range, then
/// nudged by -1, 0 or +1 ulp.
pub fn brick_face_points(d: &Derivation, vol: &LatticeVolume, base: &[[f32; 4]], edge: usize) -> Vec<[f32; 4]> {
    let r = support_radius(d) as f32 + 1.0;
    base.iter()
        .enumerate()
        .map(|(i, p)| {
            let mut q = *p;
            let a = i % 3;
            let hi = vol.dims[a] as f32 - 1.0 - r;
            let face = ((p[a] / edge as f32).round() * edge as f32).clamp(r, hi);
            let face = if (face / edge as f32).fract() == 0.0 { face } else { p[a] };
            q[a] = match (i / 3) % 3 {
                0 => face.next_down(),
                1 => face,
                _ => face.next_up(),
            };
            q
        })
        .collect()
}

/// The data range of a volume (at least the smallest positive f32).
pub fn data_range(vol: &LatticeVolume) -> f64 {
    let (lo, hi) = vol.data.iter().fold((f32::INFINITY, f32::NEG_INFINITY), |(a, b), &v| (a.min(v), b.max(v)));
    (hi - lo).max(f32::MIN_POSITIVE) as f64
}
