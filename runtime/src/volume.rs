//! CPU-side volume handling: Cartesian volumes from NIfTI or raw files, the
//! Marschner-Lobb test signal, and lattice (cc/bcc/fcc) sample sets with
//! their embedded and coset-packed storage layouts (BOX_SPLINES.md §1, §5).
//!
//! Nothing here panics on bad input: files, specs and hand-built structs with
//! inconsistent fields all come back as [`VolumeError`]s (or, for the
//! infallible accessors, as documented neutral values).

use boxforge::emit::{coset_of, coset_pivots};
use boxforge::spec::lattice::Lattice;
use std::f64::consts::PI;
use std::path::{Path, PathBuf};

/// Everything that can go wrong while loading or converting volumes. Each
/// message names the problem and how to fix it.
#[derive(Debug, thiserror::Error)]
pub enum VolumeError {
    /// The file could not be opened or read.
    #[error("cannot read {path}: {source} (check the path and its permissions)")]
    Io { path: PathBuf, source: std::io::Error },
    /// The NIfTI reader rejected the file (bad magic, header or truncated data).
    #[error(
        "{path} is not a readable NIfTI-1 file: {message} (give a .nii or .nii.gz file, or a raw file with --raw NX,NY,NZ,TYPE)"
    )]
    Nifti { path: PathBuf, message: String },
    /// The NIfTI file is not a single 3-D volume.
    #[error(
        "{path} holds {rank}-D data with dims {dims:?}: boxforge needs one 3-D scalar volume (extract a single 3-D volume first, e.g. the first time point)"
    )]
    NotThreeD { path: PathBuf, rank: usize, dims: Vec<usize> },
    /// The NIfTI voxel type is not a real scalar (complex, RGB, float128, ...).
    #[error(
        "{path} stores {data_type} voxels: boxforge reads real scalar types only (u8..u64, i8..i64, f32, f64); convert the volume to float32"
    )]
    UnsupportedNiftiType { path: PathBuf, data_type: String },
    /// Some samples are NaN or infinite.
    #[error(
        "{path}: {count} of {total} values are NaN or infinite (first at voxel ({}, {}, {})); boxforge needs finite samples: replace them (e.g. with 0 or the background value) before loading",
        first[0], first[1], first[2]
    )]
    NonFinite { path: PathBuf, count: usize, total: usize, first: [usize; 3] },
    /// A raw file's size does not match its declared dims and type.
    #[error(
        "{path} has {actual} bytes but {}x{}x{} {ty} samples need {expected} bytes: check the dims and sample type (and that the file has no header)",
        dims[0], dims[1], dims[2]
    )]
    RawSize { path: PathBuf, dims: [usize; 3], ty: &'static str, expected: u64, actual: u64 },
    /// Dims with a zero entry, or too large to address.
    #[error("bad volume dims {}x{}x{}: {reason}", dims[0], dims[1], dims[2])]
    BadDims { dims: [usize; 3], reason: String },
    /// The data vector does not have dims[0]*dims[1]*dims[2] entries.
    #[error("the volume has {len} values but dims {}x{}x{} need {expected}: build it with matching dims and data", dims[0], dims[1], dims[2])]
    DataLength { dims: [usize; 3], len: usize, expected: usize },
    /// Unknown raw sample type.
    #[error("unknown raw sample type '{given}': use u8, u16 (little endian) or f32 (little endian)")]
    BadRawType { given: String },
    /// A malformed NX,NY,NZ,TYPE spec.
    #[error("bad raw volume spec '{spec}': {reason} (expected NX,NY,NZ,TYPE, e.g. 256,256,128,u8)")]
    BadRawSpec { spec: String, reason: String },
    /// The lattice is not 3-D.
    #[error("lattice {lattice} is {dim}-D: lattice volumes are 3-D; use cc, bcc, fcc or a 3-D custom lattice")]
    LatticeDim { lattice: String, dim: usize },
    /// A non-finite or non-positive resampling scale.
    #[error("bad resampling scale {scale}: give a finite scale > 0 (Cartesian voxels per lattice unit)")]
    BadScale { scale: f64 },
    /// The lattice has no coset-packed layout, or the packed grid is too large.
    #[error("no packed layout for lattice {lattice}: {message}")]
    Packed { lattice: String, message: String },
}

/// A scalar volume on a Cartesian grid, x fastest: value(i,j,k) = data[i + nx*(j + ny*k)].
#[derive(Clone, Debug, PartialEq)]
pub struct Volume {
    /// Samples per axis (nx, ny, nz).
    pub dims: [usize; 3],
    /// The samples, x fastest.
    pub data: Vec<f32>,
}

/// Sample types of headerless raw volume files.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RawType {
    /// Unsigned 8-bit.
    U8,
    /// Unsigned 16-bit, little endian.
    U16,
    /// IEEE 32-bit float, little endian.
    F32,
}

impl RawType {
    /// Parse "u8", "u16" or "f32" (case-insensitive; "uint8", "uint16", "float32" also accepted).
    pub fn parse(s: &str) -> Result<RawType, VolumeError> {
        match s.trim().to_ascii_lowercase().as_str() {
            "u8" | "uint8" => Ok(RawType::U8),
            "u16" | "uint16" => Ok(RawType::U16),
            "f32" | "float32" | "float" => Ok(RawType::F32),
            _ => Err(VolumeError::BadRawType { given: s.to_string() }),
        }
    }

    /// Bytes per sample.
    pub fn size(self) -> usize {
        match self {
            RawType::U8 => 1,
            RawType::U16 => 2,
            RawType::F32 => 4,
        }
    }

    /// The canonical name ("u8", "u16", "f32").
    pub fn name(self) -> &'static str {
        match self {
            RawType::U8 => "u8",
            RawType::U16 => "u16",
            RawType::F32 => "f32",
        }
    }
}

/// Parse a raw volume spec "NX,NY,NZ,TYPE" (e.g. "256,256,128,u8") into dims and sample type.
pub fn parse_raw_spec(spec: &str) -> Result<([usize; 3], RawType), VolumeError> {
    let bad = |reason: String| VolumeError::BadRawSpec { spec: spec.to_string(), reason };
    let parts: Vec<&str> = spec.split(',').map(str::trim).collect();
    if parts.len() != 4 {
        return Err(bad(format!("found {} comma-separated fields, need 4", parts.len())));
    }
    let mut dims = [0usize; 3];
    for (a, (d, p)) in dims.iter_mut().zip(&parts[..3]).enumerate() {
        let axis = ["NX", "NY", "NZ"][a];
        *d = p.parse::<usize>().map_err(|_| bad(format!("{axis} = '{p}' is not a positive integer")))?;
        if *d == 0 {
            return Err(bad(format!("{axis} is 0; every dimension must be at least 1")));
        }
    }
    let ty = RawType::parse(parts[3]).map_err(|_| bad(format!("TYPE = '{}' is not one of u8, u16, f32", parts[3])))?;
    Ok((dims, ty))
}

/// Number of samples of a box, or an error for zero or overflowing dims.
fn checked_count(dims: [usize; 3]) -> Result<usize, VolumeError> {
    if dims.contains(&0) {
        return Err(VolumeError::BadDims { dims, reason: "every dimension must be at least 1".into() });
    }
    dims.iter()
        .try_fold(1usize, |acc, &d| acc.checked_mul(d))
        .filter(|&n| n <= isize::MAX as usize / 8)
        .ok_or_else(|| VolumeError::BadDims { dims, reason: "too many samples to address; use smaller dims".into() })
}

/// Errors with the count and first position of non-finite values.
fn check_finite(path: &Path, dims: [usize; 3], data: &[f32]) -> Result<(), VolumeError> {
    let mut count = 0;
    let mut first = None;
    for (i, v) in data.iter().enumerate() {
        if !v.is_finite() {
            count += 1;
            first.get_or_insert(i);
        }
    }
    match first {
        None => Ok(()),
        Some(i) => Err(VolumeError::NonFinite {
            path: path.to_path_buf(),
            count,
            total: data.len(),
            first: [i % dims[0], (i / dims[0]) % dims[1], i / (dims[0] * dims[1])],
        }),
    }
}

fn nifti_error(path: &Path, e: nifti::NiftiError) -> VolumeError {
    match e {
        nifti::NiftiError::Io(source) => VolumeError::Io { path: path.to_path_buf(), source },
        other => VolumeError::Nifti { path: path.to_path_buf(), message: other.to_string() },
    }
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

    /// Load a NIfTI-1 file (.nii or .nii.gz; scl_slope/scl_inter applied). Trailing
    /// singleton dimensions (e.g. a 4-D file with one time point) are dropped;
    /// anything else that is not 3-D, non-scalar voxel types and NaN/inf values are errors.
    pub fn load_nifti(path: &Path) -> Result<Volume, VolumeError> {
        use nifti::{IntoNdArray, NiftiObject, NiftiType, NiftiVolume, ReaderOptions};
        let obj = ReaderOptions::new().read_file(path).map_err(|e| nifti_error(path, e))?;
        let data_type = obj.volume().data_type();
        let scalar = matches!(
            data_type,
            NiftiType::Uint8
                | NiftiType::Int8
                | NiftiType::Uint16
                | NiftiType::Int16
                | NiftiType::Uint32
                | NiftiType::Int32
                | NiftiType::Uint64
                | NiftiType::Int64
                | NiftiType::Float32
                | NiftiType::Float64
        );
        if !scalar {
            return Err(VolumeError::UnsupportedNiftiType {
                path: path.to_path_buf(),
                data_type: format!("{data_type:?}"),
            });
        }
        let shape: Vec<usize> = obj.volume().dim().iter().map(|&d| d as usize).collect();
        if shape.len() < 3 || shape[3..].iter().any(|&d| d != 1) {
            return Err(VolumeError::NotThreeD { path: path.to_path_buf(), rank: shape.len(), dims: shape });
        }
        let dims = [shape[0], shape[1], shape[2]];
        checked_count(dims)?;
        let array = obj.into_volume().into_ndarray::<f32>().map_err(|e| nifti_error(path, e))?;
        // The array is indexed (x, y, z, ...); reversing the axes makes its
        // logical (row-major) order x fastest, whatever the memory order.
        let data: Vec<f32> = array.t().iter().copied().collect();
        check_finite(path, dims, &data)?;
        Volume::new(dims, data)
    }

    /// Load a headerless raw file of `dims` samples of type `ty`, x fastest.
    /// Errors when the file size is not dims*size bytes, and on NaN/inf (f32).
    pub fn load_raw(path: &Path, dims: [usize; 3], ty: RawType) -> Result<Volume, VolumeError> {
        let count = checked_count(dims)?;
        let io = |source| VolumeError::Io { path: path.to_path_buf(), source };
        let expected = (count as u64).saturating_mul(ty.size() as u64);
        let actual = std::fs::metadata(path).map_err(io)?.len();
        if actual != expected {
            return Err(VolumeError::RawSize { path: path.to_path_buf(), dims, ty: ty.name(), expected, actual });
        }
        let bytes = std::fs::read(path).map_err(io)?;
        if bytes.len() as u64 != expected {
            // The file changed between the size check and the read.
            return Err(VolumeError::RawSize {
                path: path.to_path_buf(),
                dims,
                ty: ty.name(),
                expected,
                actual: bytes.len() as u64,
            });
        }
        let data: Vec<f32> = match ty {
            RawType::U8 => bytes.iter().map(|&b| b as f32).collect(),
            RawType::U16 => bytes.chunks_exact(2).map(|c| u16::from_le_bytes([c[0], c[1]]) as f32).collect(),
            RawType::F32 => bytes.chunks_exact(4).map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]])).collect(),
        };
        check_finite(path, dims, &data)?;
        Volume::new(dims, data)
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

/// Marschner-Lobb parameters (BOX_SPLINES.md §5).
const ML_FM: f64 = 6.0;
const ML_ALPHA: f64 = 0.25;

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

/// Lattice membership in a box, through one period of the lattice: p_i e_i is
/// in L for the per-axis periods p_i (which divide |det G|), so membership of j
/// only depends on j mod p.
struct Membership {
    period: [usize; 3],
    table: Vec<bool>,
}

impl Membership {
    fn new(lattice: &Lattice) -> Result<Membership, VolumeError> {
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

    fn contains(&self, j: [usize; 3]) -> bool {
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
    /// Fill a box by evaluating `f` at every lattice point (0 elsewhere).
    fn from_fn(
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

    /// Marschner-Lobb sampled on L: lattice point j maps to x = -1 + 2 j / (n - 1) per axis (n = dims).
    /// Tip: BCC with dims 2k per axis holds two interleaved k^3 grids (2 k^3 samples, as published).
    pub fn marschner_lobb(lattice: &Lattice, dims: [usize; 3]) -> Result<LatticeVolume, VolumeError> {
        LatticeVolume::from_fn(lattice, dims, |j| {
            marschner_lobb(ml_position(dims, [j[0] as f64, j[1] as f64, j[2] as f64])) as f32
        })
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

    /// Coset grid size g = ceil(dims / 2) per axis and the coset pivots, checked to fit i32.
    fn packed_shape(&self) -> Result<([usize; 3], usize, Vec<usize>), VolumeError> {
        let err = |message: String| VolumeError::Packed { lattice: self.lattice.name.clone(), message };
        if self.lattice.dim() != 3 {
            return Err(VolumeError::LatticeDim { lattice: self.lattice.name.clone(), dim: self.lattice.dim() });
        }
        let pivots = coset_pivots(&self.lattice).map_err(|e| err(e.to_string()))?;
        let g = self.dims.map(|n| n.div_ceil(2));
        let words = g[0] * g[1] * g[2];
        let total = words.checked_mul(1 << pivots.len());
        match total {
            Some(t) if t <= i32::MAX as usize && !g.contains(&0) => Ok((g, words, pivots)),
            _ => Err(err(format!(
                "dims {:?} need more than i32::MAX words (or are empty); use a smaller volume",
                self.dims
            ))),
        }
    }

    /// Packed layout for the storage buffer of the emitted `<f>_fetch` (see
    /// templates/fetch_packed.wgsl.j2): coset grid size g = ceil(dims / 2) per axis, words per
    /// coset = gx*gy*gz, sample j stored at coset_of(pivots, j) * words + lin(j >> 1) with
    /// lin(m) = (m.z * gy + m.y) * gx + m.x; returns (buffer words, [gx, gy, gz, words]).
    ///
    /// With an odd dim, a coset whose points on that axis are odd has one slot past the box;
    /// it holds the value of the same-coset point two steps back, so the shader's clamped
    /// fetch replicates the boundary of each coset (a coset with no point on an axis of
    /// size 1 gets 0).
    pub fn packed(&self) -> Result<(Vec<f32>, [i32; 4]), VolumeError> {
        let (g, words, pivots) = self.packed_shape()?;
        let expected = checked_count(self.dims)?;
        if self.data.len() != expected {
            return Err(VolumeError::DataLength { dims: self.dims, len: self.data.len(), expected });
        }
        let cosets = 1usize << pivots.len();
        // Parity vector of each coset: parities on the pivot axes from the coset id,
        // the others fixed by membership (the parity patterns of L are spanned by
        // the reduced basis, so the pivot bits determine the rest).
        let mut parity = vec![None; cosets];
        for bits in 0..8usize {
            let r = [(bits & 1) as i64, ((bits >> 1) & 1) as i64, ((bits >> 2) & 1) as i64];
            if self.lattice.contains(&r) {
                parity[coset_of(&pivots, &r)].get_or_insert(r);
            }
        }
        let mut buf = vec![0f32; cosets * words];
        let [nx, ny, _] = self.dims;
        for (c, r) in parity.iter().enumerate() {
            let Some(r) = r else { continue };
            for mz in 0..g[2] {
                for my in 0..g[1] {
                    for mx in 0..g[0] {
                        let m = [mx, my, mz];
                        let mut j = [0usize; 3];
                        let mut inside = true;
                        for a in 0..3 {
                            let mut v = 2 * m[a] + r[a] as usize;
                            if v >= self.dims[a] {
                                // Past the box (odd dim): replicate the last same-parity point.
                                match v.checked_sub(2) {
                                    Some(w) => v = w,
                                    None => inside = false,
                                }
                            }
                            j[a] = v;
                        }
                        if inside {
                            buf[c * words + (mz * g[1] + my) * g[0] + mx] = self.data[j[0] + nx * (j[1] + ny * j[2])];
                        }
                    }
                }
            }
        }
        Ok((buf, [g[0] as i32, g[1] as i32, g[2] as i32, words as i32]))
    }

    /// Bytes of the embedded texture (4 per integer point of the box), for memory reports.
    pub fn embedded_bytes(&self) -> usize {
        4 * self.dims.iter().product::<usize>()
    }

    /// Bytes of the packed buffer (4 per word; one word per sample when dims are even;
    /// 0 when the lattice has no packed layout).
    pub fn packed_bytes(&self) -> usize {
        self.packed_shape().map(|(_, words, pivots)| 4 * (words << pivots.len())).unwrap_or(0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn lattice(name: &str) -> Lattice {
        Lattice::builtin(name).unwrap()
    }

    /// A unique temp path, removed on drop.
    struct Temp(PathBuf);
    impl Temp {
        fn new(name: &str, bytes: &[u8]) -> Temp {
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

    fn mni_path() -> PathBuf {
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../data/mni152_t1_1mm.nii.gz")
    }

    #[test]
    fn nifti_mni152_loads() {
        let v = Volume::load_nifti(&mni_path()).unwrap();
        assert_eq!(v.dims, [197, 233, 189]);
        assert_eq!(v.data.len(), 197 * 233 * 189);
        let (lo, hi) = v.range();
        assert_eq!(lo, 0.0);
        assert_eq!(hi, 255.0);
        // u8 voxels come through as exact integers.
        assert!(v.data.iter().all(|&x| x.fract() == 0.0 && (0.0..=255.0).contains(&x)));
        // A head: mostly background at the corners, tissue in the middle, and the
        // numbers of the file (1886539 non-zero voxels, checked with Python).
        assert_eq!(v.get(0, 0, 0), 0.0);
        assert!(v.get(98, 116, 94) > 0.0);
        assert_eq!(v.data.iter().filter(|&&x| x > 0.0).count(), 1_886_539);
        // x fastest: the volume is left-right symmetric (a symmetric template), so
        // mirroring x keeps most of it, while mirroring z (top-bottom) does not.
        let [nx, ny, nz] = v.dims;
        let diff = |f: &dyn Fn(usize, usize, usize) -> usize| -> f64 {
            let mut s = 0.0;
            for k in 0..nz {
                for j in 0..ny {
                    for i in 0..nx {
                        s += (v.data[i + nx * (j + ny * k)] - v.data[f(i, j, k)]).abs() as f64;
                    }
                }
            }
            s
        };
        let mx = diff(&|i, j, k| (nx - 1 - i) + nx * (j + ny * k));
        let mz = diff(&|i, j, k| i + nx * (j + ny * (nz - 1 - k)));
        assert!(mx * 3.0 < mz, "x mirror {mx} vs z mirror {mz}");
    }

    #[test]
    fn nifti_errors_are_reported() {
        let missing = Volume::load_nifti(Path::new("/nonexistent/volume.nii")).unwrap_err();
        assert!(matches!(missing, VolumeError::Io { .. }), "{missing}");
        assert!(missing.to_string().contains("/nonexistent/volume.nii"));
        let junk = Temp::new("junk.nii", &[7u8; 400]);
        let e = Volume::load_nifti(&junk.0).unwrap_err();
        assert!(matches!(e, VolumeError::Nifti { .. } | VolumeError::Io { .. }), "{e}");
        // A truncated gzip stream of the real file.
        let bytes = std::fs::read(mni_path()).unwrap();
        let cut = Temp::new("cut.nii.gz", &bytes[..bytes.len() / 2]);
        let e = Volume::load_nifti(&cut.0).unwrap_err();
        assert!(!e.to_string().is_empty());
    }

    /// A minimal uncompressed NIfTI-1 file with f32 data.
    fn nifti_f32(dim: &[u16], data: &[f32]) -> Vec<u8> {
        let mut h = vec![0u8; 352];
        h[0..4].copy_from_slice(&348i32.to_le_bytes());
        let mut d = [1i16; 8];
        d[0] = dim.len() as i16;
        for (i, &x) in dim.iter().enumerate() {
            d[i + 1] = x as i16;
        }
        for (i, x) in d.iter().enumerate() {
            h[40 + 2 * i..42 + 2 * i].copy_from_slice(&x.to_le_bytes());
        }
        h[70..72].copy_from_slice(&16i16.to_le_bytes()); // float32
        h[72..74].copy_from_slice(&32i16.to_le_bytes());
        for i in 0..8 {
            h[76 + 4 * i..80 + 4 * i].copy_from_slice(&1f32.to_le_bytes());
        }
        h[108..112].copy_from_slice(&352f32.to_le_bytes());
        h[112..116].copy_from_slice(&1f32.to_le_bytes()); // scl_slope
        h[344..348].copy_from_slice(b"n+1\0");
        for x in data {
            h.extend_from_slice(&x.to_le_bytes());
        }
        h
    }

    #[test]
    fn nifti_nan_and_rank_errors() {
        let mut data: Vec<f32> = (0..24).map(|x| x as f32).collect();
        let ok = Temp::new("ok.nii", &nifti_f32(&[2, 3, 4], &data));
        let v = Volume::load_nifti(&ok.0).unwrap();
        assert_eq!(v.dims, [2, 3, 4]);
        assert_eq!(v.data, data, "x fastest");
        let four = Temp::new("four1.nii", &nifti_f32(&[2, 3, 4, 1], &data));
        assert_eq!(Volume::load_nifti(&four.0).unwrap().dims, [2, 3, 4]);
        let two = Temp::new("two.nii", &nifti_f32(&[6, 4], &data));
        let e = Volume::load_nifti(&two.0).unwrap_err();
        assert!(matches!(e, VolumeError::NotThreeD { rank: 2, .. }), "{e}");
        let four = Temp::new("four2.nii", &nifti_f32(&[2, 3, 2, 2], &data));
        let e = Volume::load_nifti(&four.0).unwrap_err();
        assert!(matches!(e, VolumeError::NotThreeD { rank: 4, .. }), "{e}");
        data[1 + 2 * (2 + 3 * 3)] = f32::NAN; // (1, 2, 3)
        data[1 + 2 * (2 + 3)] = f32::INFINITY; // (1, 2, 1), the first
        let nan = Temp::new("nan.nii", &nifti_f32(&[2, 3, 4], &data));
        let e = Volume::load_nifti(&nan.0).unwrap_err();
        assert!(matches!(e, VolumeError::NonFinite { count: 2, first: [1, 2, 1], .. }), "{e}");
        assert!(e.to_string().contains("2 of 24") && e.to_string().contains("(1, 2, 1)"), "{e}");
    }

    #[test]
    fn raw_round_trip() {
        let dims = [3, 4, 5];
        let n = 60;
        let u8s: Vec<u8> = (0..n).map(|i| (i * 4) as u8).collect();
        let f = Temp::new("rt.u8", &u8s);
        let v = Volume::load_raw(&f.0, dims, RawType::U8).unwrap();
        assert_eq!(v.data, u8s.iter().map(|&b| b as f32).collect::<Vec<_>>());
        assert_eq!(v.range(), (0.0, 236.0));

        let u16s: Vec<u16> = (0..n).map(|i| (i * 1000 + 7) as u16).collect();
        let bytes: Vec<u8> = u16s.iter().flat_map(|x| x.to_le_bytes()).collect();
        let f = Temp::new("rt.u16", &bytes);
        let v = Volume::load_raw(&f.0, dims, RawType::U16).unwrap();
        assert_eq!(v.data, u16s.iter().map(|&x| x as f32).collect::<Vec<_>>());
        assert_eq!(v.get(2, 3, 4), 59007.0);

        let f32s: Vec<f32> = (0..n).map(|i| (i as f32 - 30.0) * 0.37).collect();
        let bytes: Vec<u8> = f32s.iter().flat_map(|x| x.to_le_bytes()).collect();
        let f = Temp::new("rt.f32", &bytes);
        let v = Volume::load_raw(&f.0, dims, RawType::F32).unwrap();
        assert_eq!(v.data, f32s);
        assert_eq!(v.get(1, 0, 0), f32s[1]);
        assert_eq!(v.get(0, 1, 0), f32s[3]);
        assert_eq!(v.get(0, 0, 1), f32s[12]);

        // Wrong size: names expected and actual bytes.
        let e = Volume::load_raw(&f.0, [4, 4, 5], RawType::F32).unwrap_err();
        assert!(matches!(e, VolumeError::RawSize { expected: 320, actual: 240, .. }), "{e}");
        let msg = e.to_string();
        assert!(msg.contains("240 bytes") && msg.contains("need 320 bytes") && msg.contains("4x4x5 f32"), "{msg}");
        let e = Volume::load_raw(&f.0, dims, RawType::U16).unwrap_err();
        assert!(matches!(e, VolumeError::RawSize { expected: 120, actual: 240, .. }), "{e}");
        let e = Volume::load_raw(&f.0, [0, 4, 5], RawType::U8).unwrap_err();
        assert!(matches!(e, VolumeError::BadDims { .. }), "{e}");
        let e = Volume::load_raw(&f.0, [usize::MAX, 4, 5], RawType::U8).unwrap_err();
        assert!(matches!(e, VolumeError::BadDims { .. }), "{e}");
        let e = Volume::load_raw(Path::new("/nonexistent/raw.u8"), dims, RawType::U8).unwrap_err();
        assert!(matches!(e, VolumeError::Io { .. }), "{e}");
    }

    #[test]
    fn raw_nan_is_an_error() {
        let mut f32s: Vec<f32> = vec![1.0; 24];
        f32s[5] = f32::NAN; // (1, 2, 0) in 2x3x4
        f32s[17] = f32::NEG_INFINITY;
        f32s[20] = f32::NAN;
        let bytes: Vec<u8> = f32s.iter().flat_map(|x| x.to_le_bytes()).collect();
        let f = Temp::new("nan.f32", &bytes);
        let e = Volume::load_raw(&f.0, [2, 3, 4], RawType::F32).unwrap_err();
        assert!(matches!(e, VolumeError::NonFinite { count: 3, total: 24, first: [1, 2, 0], .. }), "{e}");
        assert!(e.to_string().contains("NaN or infinite"), "{e}");
    }

    #[test]
    fn raw_spec_parsing() {
        assert_eq!(parse_raw_spec("256,256,128,u8").unwrap(), ([256, 256, 128], RawType::U8));
        assert_eq!(parse_raw_spec(" 4, 5 ,6,F32").unwrap(), ([4, 5, 6], RawType::F32));
        assert_eq!(RawType::parse("u16").unwrap(), RawType::U16);
        assert!(matches!(RawType::parse("i32"), Err(VolumeError::BadRawType { .. })));
        for (spec, needle) in [
            ("256,256,u8", "3 comma-separated fields"),
            ("256,256,128,64,u8", "5 comma-separated fields"),
            ("256,x,128,u8", "NY = 'x'"),
            ("256,256,-1,u8", "NZ = '-1'"),
            ("0,256,128,u8", "NX is 0"),
            ("256,256,128,i32", "TYPE = 'i32'"),
            ("", "1 comma-separated"),
        ] {
            let e = parse_raw_spec(spec).unwrap_err();
            let msg = e.to_string();
            assert!(msg.contains(needle) && msg.contains("NX,NY,NZ,TYPE"), "{spec}: {msg}");
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

    /// Independent membership rules of BOX_SPLINES.md §1.
    fn member(name: &str, j: [usize; 3]) -> bool {
        match name {
            "cc" => true,
            "bcc" => j[0] % 2 == j[1] % 2 && j[1] % 2 == j[2] % 2,
            "fcc" => (j[0] + j[1] + j[2]).is_multiple_of(2),
            _ => unreachable!(),
        }
    }

    /// Lattice points in a box, by formula: BCC = all-even + all-odd points;
    /// FCC = (N + s_x s_y s_z) / 2 with s = #even - #odd = n mod 2 per axis.
    fn expected_samples(name: &str, d: [usize; 3]) -> usize {
        match name {
            "cc" => d[0] * d[1] * d[2],
            "bcc" => d.map(|n| n.div_ceil(2)).iter().product::<usize>() + d.map(|n| n / 2).iter().product::<usize>(),
            "fcc" => (d[0] * d[1] * d[2] + d.map(|n| n % 2).iter().product::<usize>()) / 2,
            _ => unreachable!(),
        }
    }

    fn test_volume(dims: [usize; 3]) -> Volume {
        let n = dims[0] * dims[1] * dims[2];
        Volume::new(dims, (0..n).map(|i| 1.0 + i as f32).collect()).unwrap()
    }

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

    /// The shader's packed fetch (templates/fetch_packed.wgsl.j2), written out
    /// by hand per lattice: coset from the parity of j, grid position j >> 1
    /// clamped to the coset grid, index = coset * words + (m.z*gy + m.y)*gx + m.x.
    fn shader_fetch(name: &str, buf: &[f32], size: [i32; 4], j: [i64; 3]) -> f32 {
        let coset = match name {
            "bcc" => j[0] & 1,
            "fcc" => (j[0] & 1) + ((j[1] & 1) << 1),
            "cc" => (j[0] & 1) + ((j[1] & 1) << 1) + ((j[2] & 1) << 2),
            _ => unreachable!(),
        };
        let m: Vec<i64> = (0..3).map(|a| (j[a] >> 1).clamp(0, size[a] as i64 - 1)).collect();
        let index = coset * size[3] as i64 + (m[2] * size[1] as i64 + m[1]) * size[0] as i64 + m[0];
        buf[index as usize]
    }

    #[test]
    fn packed_layout_matches_the_shader_index() {
        assert_eq!(coset_pivots(&lattice("bcc")).unwrap(), vec![0]);
        assert_eq!(coset_pivots(&lattice("fcc")).unwrap(), vec![0, 1]);
        assert_eq!(coset_pivots(&lattice("cc")).unwrap(), vec![0, 1, 2]);
        for name in ["cc", "bcc", "fcc"] {
            for dims in [[8, 8, 8], [7, 6, 5], [10, 4, 6], [1, 2, 3]] {
                let l = LatticeVolume::subset(&lattice(name), &test_volume(dims)).unwrap();
                let (buf, size) = l.packed().unwrap();
                let g = dims.map(|n| n.div_ceil(2) as i32);
                assert_eq!(size, [g[0], g[1], g[2], g[0] * g[1] * g[2]]);
                let cosets = 8 / l.lattice.det() as usize;
                assert_eq!(buf.len(), cosets * size[3] as usize);
                assert_eq!(l.packed_bytes(), 4 * buf.len());
                assert_eq!(l.embedded_bytes(), 4 * dims.iter().product::<usize>());
                // Every lattice point of the box is found where the shader looks.
                let mut seen = vec![false; buf.len()];
                for k in 0..dims[2] as i64 {
                    for j in 0..dims[1] as i64 {
                        for i in 0..dims[0] as i64 {
                            if member(name, [i as usize, j as usize, k as usize]) {
                                assert_eq!(shader_fetch(name, &buf, size, [i, j, k]), l.get(&[i, j, k]));
                                let coset = match name {
                                    "bcc" => i & 1,
                                    "fcc" => (i & 1) + ((j & 1) << 1),
                                    _ => (i & 1) + ((j & 1) << 1) + ((k & 1) << 2),
                                };
                                let idx = coset * size[3] as i64
                                    + ((k >> 1) * size[1] as i64 + (j >> 1)) * size[0] as i64
                                    + (i >> 1);
                                assert!(!seen[idx as usize], "two samples share word {idx}");
                                seen[idx as usize] = true;
                            }
                        }
                    }
                }
                let used = seen.iter().filter(|&&s| s).count();
                assert_eq!(used, l.samples());
                if dims.iter().all(|n| n % 2 == 0) {
                    // Exactly one word per sample; the embedded texture costs det x.
                    assert_eq!(buf.len(), l.samples());
                    assert_eq!(l.packed_bytes(), 4 * l.samples());
                    assert_eq!(l.embedded_bytes(), l.packed_bytes() * l.lattice.det() as usize);
                }
                // Outside the box, the fetch replicates the nearest in-box point of
                // the same coset (same parity per axis), when there is one.
                for k in -2..dims[2] as i64 + 2 {
                    for j in -2..dims[1] as i64 + 2 {
                        for i in -2..dims[0] as i64 + 2 {
                            let p = [i, j, k];
                            if !l.is_lattice(&p) {
                                continue;
                            }
                            let near: Option<Vec<i64>> = (0..3)
                                .map(|a| {
                                    let n = dims[a] as i64;
                                    let par = p[a].rem_euclid(2);
                                    let hi = if (n - 1) % 2 == par { n - 1 } else { n - 2 };
                                    (hi >= par).then(|| p[a].clamp(par, hi))
                                })
                                .collect();
                            if let Some(q) = near {
                                assert_eq!(shader_fetch(name, &buf, size, p), l.get(&q), "{name} {dims:?} {p:?}");
                            }
                        }
                    }
                }
            }
        }
        // The real-world sizes: BCC / FCC subsets of the MNI head.
        let vol = Volume::load_nifti(&mni_path()).unwrap();
        for (name, det) in [("bcc", 4), ("fcc", 2)] {
            let l = LatticeVolume::subset(&lattice(name), &vol).unwrap();
            let (buf, _) = l.packed().unwrap();
            assert_eq!(l.samples(), expected_samples(name, vol.dims));
            // Odd dims waste at most a boundary layer per coset.
            assert!(buf.len() >= l.samples() && buf.len() < l.samples() * 103 / 100, "{name}");
            let ratio = l.embedded_bytes() as f64 / l.packed_bytes() as f64;
            assert!((ratio - det as f64).abs() < 0.05 * det as f64, "{name}: embedded/packed = {ratio}");
        }
    }

    #[test]
    fn packed_rejects_lattices_without_2z3() {
        // det 3: 2Z^3 is not a sublattice.
        let l3 = Lattice::from_generators("custom", vec![vec![1, 0, 0], vec![0, 1, 0], vec![1, 1, 3]]).unwrap();
        let v = LatticeVolume::subset(&l3, &test_volume([6, 6, 6])).unwrap();
        assert_eq!(v.samples(), (0..216).filter(|&i| l3.contains(&[i % 6, (i / 6) % 6, i / 36])).count());
        let e = v.packed().unwrap_err();
        assert!(matches!(e, VolumeError::Packed { .. }), "{e}");
        assert!(e.to_string().contains("embedded"), "{e}");
        assert_eq!(v.packed_bytes(), 0);
        // Hand-built inconsistent struct: errors, not panics.
        let bad = LatticeVolume { lattice: lattice("bcc"), dims: [4, 4, 4], data: vec![1.0; 10] };
        assert!(matches!(bad.packed(), Err(VolumeError::DataLength { .. })));
        assert_eq!(bad.get(&[3, 3, 3]), 0.0);
    }
}
