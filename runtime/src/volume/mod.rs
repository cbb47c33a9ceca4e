//! CPU-side volume handling: the Cartesian [`Volume`] and lattice
//! [`LatticeVolume`] types, their accessors and the re-exports of the rest,
//! which lives beside them one concern per file: `error.rs` (the error type
//! and shared input checks), `nifti.rs` and `raw.rs` (file formats),
//! `synthetic.rs` (the Marschner-Lobb test signal), `series.rs` (time
//! series of volumes, 4D data), `convert.rs` (lattice
//! (cc/bcc/fcc) sample sets from Cartesian volumes), `lattice_sources.rs`
//! (the same resampled and prefiltered box by box) and `packing.rs` (the
//! coset-packed storage layout) (docs/BOX_SPLINES.md §1, §5); `stream.rs`
//! maps a file and reads it box by box, with the stored sample types in
//! `stored.rs`, its own NIfTI-1 header reader in `nifti_header.rs` and the
//! `.nii.gz` cache in `gz_cache.rs`.
//!
//! Nothing here panics on bad input: files, specs and hand-built structs with
//! inconsistent fields all come back as [`VolumeError`]s (or, for the
//! infallible accessors, as documented neutral values).

use boxforge::spec::lattice::Lattice;

mod bricks;
mod convert;
mod device;
mod error;
mod format;
mod four;
#[cfg(feature = "files")]
mod gz_cache;
mod lattice_sources;
#[cfg(feature = "nifti")]
mod nifti;
#[cfg(feature = "files")]
mod nifti_header;
#[cfg(not(feature = "nifti"))]
mod nifti_off;
mod packing;
mod raw;
mod series;
mod source;
#[cfg(feature = "files")]
mod stored;
#[cfg(feature = "files")]
mod stream;
mod synthetic;
#[cfg(test)]
mod testutil;
#[cfg(feature = "zarr")]
pub mod zarr;

pub use bricks::{slot_grid, BrickShape, BrickedVolume};
pub use device::{DeviceVolume, VolumeOptions, DEFAULT_HALO};
pub use error::VolumeError;
pub use format::SampleFormat;
pub use four::{DeviceVolume4, LatticeVolume4};
#[cfg(feature = "files")]
pub use gz_cache::default_cache_dir;
pub use lattice_sources::{matched_lattice, Prefiltered, Resampled, Window};
pub use packing::PackedVolume;
pub use raw::{parse_raw_spec, RawType};
pub use series::{marschner_lobb_drift, ml_drift_frequency, VolumeSeries};
pub use source::{check_box_len, BrickSource};
#[cfg(feature = "files")]
pub use stream::MappedVolume;
pub use synthetic::{marschner_lobb, marschner_lobb_grad, marschner_lobb_hessian, ml_position};

use error::checked_count;

/// How far a filter's support reaches from a point, in lattice units along
/// each axis, rounded up: the largest half-width of the generator's
/// zonotope ([`SplineFacts::support_half_width`] along each axis). The
/// margin the renderers keep around a volume's box, and the room the
/// device checks leave inside theirs.
///
/// [`SplineFacts::support_half_width`]: boxforge::derive::spline::SplineFacts::support_half_width
pub fn support_radius(d: &boxforge::derive::Derivation) -> usize {
    (0..d.facts.dim)
        .map(|i| {
            let axis: Vec<i64> = (0..d.facts.dim).map(|j| i64::from(i == j)).collect();
            let half = d.facts.support_half_width(&axis);
            let floor = half.floor_i64().expect("a support's half-width is a small rational");
            (floor + i64::from(!half.is_integer())) as usize
        })
        .max()
        .unwrap_or(1)
}

/// A scalar volume on a Cartesian grid, x fastest: value(i,j,k) = data[i + nx*(j + ny*k)].
#[derive(Clone, Debug, PartialEq)]
pub struct Volume {
    /// Samples per axis (nx, ny, nz).
    pub dims: [usize; 3],
    /// The samples, x fastest.
    pub data: Vec<f32>,
}

impl Volume {
    /// A volume from dims and x-fastest data; errors on zero dims or a length mismatch.
    pub fn new(dims: [usize; 3], data: Vec<f32>) -> Result<Volume, VolumeError> {
        let expected = checked_count(dims)?;
        if data.len() != expected {
            return Err(VolumeError::DataLength { dims, len: data.len(), expected });
        }
        Ok(Volume { dims, data })
    }

    /// (min, max) of the samples; (0, 0) for an empty volume. NaNs are ignored.
    pub fn range(&self) -> (f32, f32) {
        let (lo, hi) = self
            .data
            .iter()
            .filter(|v| !v.is_nan())
            .fold((f32::INFINITY, f32::NEG_INFINITY), |(lo, hi), &v| (lo.min(v), hi.max(v)));
        if lo > hi {
            (0.0, 0.0)
        } else {
            (lo, hi)
        }
    }

    /// The sample at (i, j, k), clamped into the grid; 0 for an empty volume.
    pub fn get(&self, i: i64, j: i64, k: i64) -> f32 {
        if self.dims.contains(&0) {
            return 0.0;
        }
        let c = |v: i64, n: usize| v.clamp(0, n as i64 - 1) as usize;
        let idx = c(i, self.dims[0]) + self.dims[0] * (c(j, self.dims[1]) + self.dims[1] * c(k, self.dims[2]));
        self.data.get(idx).copied().unwrap_or(0.0)
    }

    /// Trilinear interpolation at a continuous voxel position (clamped to the grid).
    pub fn trilinear(&self, p: [f64; 3]) -> f64 {
        let mut base = [0i64; 3];
        let mut t = [0f64; 3];
        for a in 0..3 {
            let n = self.dims[a].max(1) as f64;
            let x = if p[a].is_nan() { 0.0 } else { p[a].clamp(0.0, n - 1.0) };
            let i0 = x.floor().min((n - 2.0).max(0.0));
            base[a] = i0 as i64;
            t[a] = x - i0;
        }
        let mut acc = 0.0;
        for corner in 0..8 {
            let o = [(corner & 1) as i64, ((corner >> 1) & 1) as i64, ((corner >> 2) & 1) as i64];
            let w: f64 = (0..3).map(|a| if o[a] == 1 { t[a] } else { 1.0 - t[a] }).product();
            if w != 0.0 {
                acc += w * self.get(base[0] + o[0], base[1] + o[1], base[2] + o[2]) as f64;
            }
        }
        acc
    }
}

/// Samples on the integer-embedded lattice L over a box [0, n)^3 of Z^3 (only lattice points carry data).
#[derive(Clone, Debug, PartialEq)]
pub struct LatticeVolume {
    /// The data lattice (3-D), embedded in Z^3.
    pub lattice: Lattice,
    /// Box size (nx, ny, nz) in Z^3 (integer points, not lattice points).
    pub dims: [usize; 3],
    /// Embedded samples, x fastest, 0 at non-lattice points.
    pub data: Vec<f32>,
}

impl LatticeVolume {
    /// (min, max) of the samples at lattice points ((0, 0) when there are
    /// none; NaNs ignored): the range compact formats spread their levels over.
    pub fn sample_range(&self) -> (f32, f32) {
        let [nx, ny, _] = self.dims;
        let (lo, hi) = self
            .data
            .iter()
            .enumerate()
            .filter(|(i, v)| {
                !v.is_nan() && self.lattice.contains(&[(i % nx) as i64, ((i / nx) % ny) as i64, (i / (nx * ny)) as i64])
            })
            .fold((f32::INFINITY, f32::NEG_INFINITY), |(lo, hi), (_, &v)| (lo.min(v), hi.max(v)));
        if lo > hi {
            (0.0, 0.0)
        } else {
            (lo, hi)
        }
    }

    /// Whether integer point `j` is a lattice point (ignores the box).
    pub fn is_lattice(&self, j: &[i64]) -> bool {
        self.lattice.contains(j)
    }

    /// Clamps j into the box, like the shaders' fetch (embedded layout); returns
    /// the stored value (0 at non-lattice points; missing coordinates count as 0).
    pub fn get(&self, j: &[i64]) -> f32 {
        if self.dims.contains(&0) {
            return 0.0;
        }
        let c = |a: usize| j.get(a).copied().unwrap_or(0).clamp(0, self.dims[a] as i64 - 1) as usize;
        let idx = c(0) + self.dims[0] * (c(1) + self.dims[1] * c(2));
        self.data.get(idx).copied().unwrap_or(0.0)
    }
}
