//! Synthetic test signals: the Marschner-Lobb function, its analytic
//! gradient, and its samples on a lattice.

use super::{LatticeVolume, VolumeError};
use boxforge::spec::lattice::Lattice;
use std::f64::consts::PI;

/// Marschner-Lobb parameters (docs/BOX_SPLINES.md §5).
pub(crate) const ML_FM: f64 = 6.0;
pub(crate) const ML_ALPHA: f64 = 0.25;

/// Marschner-Lobb (f_M = 6, alpha = 0.25) on [-1,1]^3 and its analytic gradient.
pub fn marschner_lobb(p: [f64; 3]) -> f64 {
    let [x, y, z] = p;
    let r = (x * x + y * y).sqrt();
    let rho_r = (2.0 * PI * ML_FM * (PI * r / 2.0).cos()).cos();
    (1.0 - (PI * z / 2.0).sin() + ML_ALPHA * (1.0 + rho_r)) / (2.0 * (1.0 + ML_ALPHA))
}

/// The analytic gradient of [`marschner_lobb`] (finite everywhere, also on the z axis).
pub fn marschner_lobb_grad(p: [f64; 3]) -> [f64; 3] {
    let [x, y, z] = p;
    let r = (x * x + y * y).sqrt();
    let norm = 2.0 * (1.0 + ML_ALPHA);
    // d rho_r / dr = pi^2 f_M sin(2 pi f_M cos(pi r / 2)) sin(pi r / 2); divide by r
    // with sin(pi r / 2) / r -> pi / 2 at r = 0.
    let sinc = if r < 1e-8 { PI / 2.0 } else { (PI * r / 2.0).sin() / r };
    let drho_over_r = PI * PI * ML_FM * (2.0 * PI * ML_FM * (PI * r / 2.0).cos()).sin() * sinc;
    let radial = ML_ALPHA * drho_over_r / norm;
    [radial * x, radial * y, -(PI / 2.0) * (PI * z / 2.0).cos() / norm]
}

/// The analytic Hessian of [`marschner_lobb`] (row-major): the radial
/// part rho(r) has Hessian rho'' r r^T / r^2 + (rho' / r)(I - r r^T / r^2)
/// in (x, y), the z part -sin(pi z / 2) only d2/dz2.
pub fn marschner_lobb_hessian(p: [f64; 3]) -> [[f64; 3]; 3] {
    let [x, y, z] = p;
    let r = (x * x + y * y).sqrt();
    let norm = 2.0 * (1.0 + ML_ALPHA);
    let u = 2.0 * PI * ML_FM * (PI * r / 2.0).cos();
    let k = PI * PI * ML_FM;
    // rho'(r) / r and rho''(r); both tend to k (pi / 2) sin(2 pi f_M) at r = 0.
    let sinc = if r < 1e-8 { PI / 2.0 } else { (PI * r / 2.0).sin() / r };
    let d1_over_r = k * u.sin() * sinc;
    let s = (PI * r / 2.0).sin();
    let d2 = k * (-k * s * s * u.cos() + (PI / 2.0) * u.sin() * (PI * r / 2.0).cos());
    let (nx, ny) = if r < 1e-8 { (0.0, 0.0) } else { (x / r, y / r) };
    let a = ML_ALPHA / norm;
    let hxx = a * (d2 * nx * nx + d1_over_r * (1.0 - nx * nx));
    let hyy = a * (d2 * ny * ny + d1_over_r * (1.0 - ny * ny));
    let hxy = a * (d2 - d1_over_r) * nx * ny;
    let hzz = (PI / 2.0) * (PI / 2.0) * (PI * z / 2.0).sin() / norm;
    [[hxx, hxy, 0.0], [hxy, hyy, 0.0], [0.0, 0.0, hzz]]
}

/// Position in [-1,1]^3 of lattice point `j` of a box of `dims` samples:
/// x = -1 + 2 j / (n - 1) per axis (0 when n = 1). Works for fractional j too.
pub fn ml_position(dims: [usize; 3], j: [f64; 3]) -> [f64; 3] {
    let mut x = [0.0; 3];
    for a in 0..3 {
        if dims[a] > 1 {
            x[a] = -1.0 + 2.0 * j[a] / (dims[a] - 1) as f64;
        }
    }
    x
}

impl LatticeVolume {
    /// Marschner-Lobb sampled on L: lattice point j maps to x = -1 + 2 j / (n - 1) per axis (n = dims).
    /// Tip: BCC with dims 2k per axis holds two interleaved k^3 grids (2 k^3 samples, as published).
    pub fn marschner_lobb(lattice: &Lattice, dims: [usize; 3]) -> Result<LatticeVolume, VolumeError> {
        LatticeVolume::from_fn(lattice, dims, |j| {
            marschner_lobb(ml_position(dims, [j[0] as f64, j[1] as f64, j[2] as f64])) as f32
        })
    }

    /// A thin spherical shell: exp(-((r - R) / w)^2 / 2) at every lattice
    /// point, r its distance (in samples) from the box centre, R = `radius`
    /// times the smallest edge, w = `width` samples. Iso-values near the
    /// spline's peak give surfaces that are slabs thinner than a ray step.
    pub fn thin_shell(
        lattice: &Lattice,
        dims: [usize; 3],
        radius: f64,
        width: f64,
    ) -> Result<LatticeVolume, VolumeError> {
        let c = dims.map(|n| (n as f64 - 1.0) / 2.0);
        let big_r = radius * dims.iter().min().copied().unwrap_or(0) as f64;
        LatticeVolume::from_fn(lattice, dims, |j| {
            let r = (0..3).map(|a| (j[a] as f64 - c[a]).powi(2)).sum::<f64>().sqrt();
            (-0.5 * ((r - big_r) / width).powi(2)).exp() as f32
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::volume::testutil::lattice;

    /// The analytic Hessian against central differences of the analytic
    /// gradient, off and on the z axis.
    #[test]
    fn marschner_lobb_hessian_matches_differences_of_the_gradient() {
        for p in [[0.31, -0.42, 0.17], [0.0, 0.0, 0.4], [-0.7, 0.05, -0.6], [1e-9, 0.0, 0.2]] {
            let h = marschner_lobb_hessian(p);
            let e = 1e-6;
            for j in 0..3 {
                let (mut a, mut b) = (p, p);
                a[j] += e;
                b[j] -= e;
                let (ga, gb) = (marschner_lobb_grad(a), marschner_lobb_grad(b));
                for i in 0..3 {
                    let fd = (ga[i] - gb[i]) / (2.0 * e);
                    assert!((h[i][j] - fd).abs() < 1e-4 * (1.0 + fd.abs()), "{p:?} h[{i}][{j}] {} vs {fd}", h[i][j]);
                }
            }
        }
    }

    #[test]
    fn marschner_lobb_values() {
        let close = |a: f64, b: f64| (a - b).abs() < 1e-12;
        assert!(close(marschner_lobb([0.0, 0.0, 0.0]), 0.6));
        assert!(close(marschner_lobb([0.0, 0.0, 1.0]), 0.2));
        assert!(close(marschner_lobb([0.0, 0.0, -1.0]), 1.0));
        assert!(close(marschner_lobb([1.0, 0.0, 0.0]), 0.6));
        // r = 2/3: cos(pi r/2) = 1/2, rho_r = cos(6 pi) = 1.
        assert!(close(marschner_lobb([0.0, 2.0 / 3.0, 0.0]), 0.6));
        // cos(pi r / 2) = 1/12 gives rho_r = cos(pi) = -1.
        let r = 2.0 * (1.0f64 / 12.0).acos() / PI;
        assert!(close(marschner_lobb([r, 0.0, 0.0]), 0.4));
    }

    #[test]
    fn marschner_lobb_gradient_matches_differences() {
        let mut seed = 0x2545f4914f6cdd1du64;
        let mut rnd = || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
        };
        let mut points = vec![[0.0, 0.0, 0.0], [0.0, 0.0, 0.5], [1e-9, -1e-9, 0.3], [1.0, 1.0, 1.0]];
        for _ in 0..200 {
            points.push([rnd(), rnd(), rnd()]);
        }
        let h = 1e-5;
        for p in points {
            let g = marschner_lobb_grad(p);
            for a in 0..3 {
                let (mut lo, mut hi) = (p, p);
                lo[a] -= h;
                hi[a] += h;
                let fd = (marschner_lobb(hi) - marschner_lobb(lo)) / (2.0 * h);
                assert!((fd - g[a]).abs() < 1e-6 * (1.0 + g[a].abs()), "{p:?} axis {a}: {} vs {fd}", g[a]);
            }
        }
    }

    #[test]
    fn marschner_lobb_on_lattices() {
        let bcc = lattice("bcc");
        let v = LatticeVolume::marschner_lobb(&bcc, [10, 10, 10]).unwrap();
        assert_eq!(v.samples(), 2 * 5 * 5 * 5);
        // (9,9,9) is a BCC point at x = (1,1,1); (0,0,0) at (-1,-1,-1); (1,0,0) is not a point.
        assert_eq!(v.get(&[9, 9, 9]), marschner_lobb([1.0, 1.0, 1.0]) as f32);
        assert_eq!(v.get(&[0, 0, 0]), marschner_lobb([-1.0, -1.0, -1.0]) as f32);
        assert_eq!(v.get(&[1, 0, 0]), 0.0);
        let p = ml_position(v.dims, [3.0, 5.0, 7.0]);
        assert_eq!(v.get(&[3, 5, 7]), marschner_lobb(p) as f32);
        // Clamping: outside the box reads the boundary.
        assert_eq!(v.get(&[12, 9, 9]), v.get(&[9, 9, 9]));
        assert_eq!(v.get(&[-3, 0, 0]), v.get(&[0, 0, 0]));
        let e = LatticeVolume::marschner_lobb(&lattice("quincunx"), [4, 4, 4]).unwrap_err();
        assert!(matches!(e, VolumeError::LatticeDim { dim: 2, .. }), "{e}");
        let e = LatticeVolume::marschner_lobb(&bcc, [4, 0, 4]).unwrap_err();
        assert!(matches!(e, VolumeError::BadDims { .. }), "{e}");
    }
}
