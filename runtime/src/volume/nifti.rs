//! Loading NIfTI-1 files (.nii, .nii.gz) into a Cartesian [`Volume`].

use super::error::{check_finite, checked_count};
use super::{Volume, VolumeError};
use std::path::Path;

fn nifti_error(path: &Path, e: nifti::NiftiError) -> VolumeError {
    match e {
        nifti::NiftiError::Io(source) => VolumeError::Io { path: path.to_path_buf(), source },
        other => VolumeError::Nifti { path: path.to_path_buf(), message: other.to_string() },
    }
}

impl Volume {
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
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::volume::testutil::{mni_path, Temp};

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
}
