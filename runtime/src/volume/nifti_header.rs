//! The NIfTI-1 header of a single-file `.nii`, parsed here for the
//! memory-mapped volumes ([`MappedVolume`](super::MappedVolume)).
//!
//! Why a parser beside the `nifti` crate: that crate reads a file's whole
//! volume into memory (and is an optional feature), while a mapped volume
//! needs only where the samples start, their type, byte order and scaling,
//! to read them box by box from the mapping with at most one box resident.
//! The rules are the crate's (data at `vox_offset`, or right after the
//! header when it is smaller; `raw * scl_slope + scl_inter` when
//! `scl_slope != 0`), so both paths give the same samples.

use super::stored::Sample;
use super::VolumeError;
use std::path::Path;

/// The NIfTI-1 header size.
pub(super) const NIFTI1_HEADER: usize = 348;

pub(super) fn nifti_err(path: &Path, message: impl Into<String>) -> VolumeError {
    VolumeError::Nifti { path: path.to_path_buf(), message: message.into() }
}

impl Sample {
    /// The NIfTI-1 datatype code, or the name of a type boxforge does not read.
    pub(super) fn from_nifti(code: i16) -> Result<Sample, String> {
        Ok(match code {
            2 => Sample::U8,
            256 => Sample::I8,
            512 => Sample::U16,
            4 => Sample::I16,
            768 => Sample::U32,
            8 => Sample::I32,
            1280 => Sample::U64,
            1024 => Sample::I64,
            16 => Sample::F32,
            64 => Sample::F64,
            1 => return Err("binary (datatype 1)".into()),
            32 => return Err("complex64 (datatype 32)".into()),
            128 => return Err("RGB24 (datatype 128)".into()),
            1536 => return Err("float128 (datatype 1536)".into()),
            1792 => return Err("complex128 (datatype 1792)".into()),
            2048 => return Err("complex256 (datatype 2048)".into()),
            2304 => return Err("RGBA32 (datatype 2304)".into()),
            other => return Err(format!("unknown datatype code {other}")),
        })
    }
}

/// The parsed NIfTI-1 header fields a mapped volume needs.
pub(super) struct NiftiHeader {
    pub(super) dims: [usize; 3],
    pub(super) ty: Sample,
    pub(super) big_endian: bool,
    pub(super) offset: usize,
    pub(super) scale: Option<(f32, f32)>,
    /// Voxel size along x, y, z (`pixdim[1..=3]`; 1 where the header has
    /// none: zero, negative or not finite).
    pub(super) voxel: [f64; 3],
    /// The space unit of `xyzt_units` (UDUNITS names, as OME-Zarr writes them).
    pub(super) unit: Option<&'static str>,
}

/// Parses the 348-byte NIfTI-1 header of a single-file volume (`name` is
/// the path errors name).
pub(super) fn parse_nifti_header(h: &[u8], name: &Path) -> Result<NiftiHeader, VolumeError> {
    if h.len() < NIFTI1_HEADER {
        return Err(nifti_err(name, format!("the file has {} bytes, less than a 348-byte NIfTI-1 header", h.len())));
    }
    let sizeof = [h[0], h[1], h[2], h[3]];
    let big_endian = if i32::from_le_bytes(sizeof) == 348 {
        false
    } else if i32::from_be_bytes(sizeof) == 348 {
        true
    } else if i32::from_le_bytes(sizeof) == 540 || i32::from_be_bytes(sizeof) == 540 {
        return Err(nifti_err(name, "it is a NIfTI-2 file, which boxforge does not map; save it as NIfTI-1"));
    } else {
        return Err(nifti_err(
            name,
            format!("sizeof_hdr is {} (neither byte order gives 348)", i32::from_le_bytes(sizeof)),
        ));
    };
    let i16_at = |o: usize| {
        let b = [h[o], h[o + 1]];
        if big_endian {
            i16::from_be_bytes(b)
        } else {
            i16::from_le_bytes(b)
        }
    };
    let f32_at = |o: usize| {
        let b = [h[o], h[o + 1], h[o + 2], h[o + 3]];
        if big_endian {
            f32::from_be_bytes(b)
        } else {
            f32::from_le_bytes(b)
        }
    };
    match &h[344..348] {
        b"n+1\0" => {}
        b"ni1\0" => {
            return Err(nifti_err(
                name,
                "it is the header of a .hdr/.img pair; boxforge maps single-file volumes: save it as one .nii",
            ))
        }
        m => return Err(nifti_err(name, format!("bad magic {m:?} (a single-file NIfTI-1 has \"n+1\\0\")"))),
    }
    let rank = i16_at(40);
    if !(1..=7).contains(&rank) {
        return Err(nifti_err(name, format!("dim[0] = {rank} is not a rank between 1 and 7")));
    }
    let shape: Vec<usize> = (1..=rank as usize).map(|i| i16_at(40 + 2 * i).max(0) as usize).collect();
    if shape.contains(&0) {
        return Err(nifti_err(name, format!("the dims {shape:?} have an entry below 1")));
    }
    if shape.len() < 3 || shape[3..].iter().any(|&d| d != 1) {
        return Err(VolumeError::NotThreeD { path: name.to_path_buf(), rank: shape.len(), dims: shape });
    }
    let dims = [shape[0], shape[1], shape[2]];
    let ty = Sample::from_nifti(i16_at(70))
        .map_err(|data_type| VolumeError::UnsupportedNiftiType { path: name.to_path_buf(), data_type })?;
    let bitpix = i16_at(72);
    if bitpix as i64 != 8 * ty.size() as i64 {
        return Err(nifti_err(
            name,
            format!(
                "bitpix is {bitpix} but {} samples have {} bits (fix the header's bitpix)",
                ty.name(),
                8 * ty.size()
            ),
        ));
    }
    let vox = f32_at(108);
    if !(vox.is_finite() && vox >= 0.0 && vox < (1u64 << 40) as f32) {
        return Err(nifti_err(name, format!("vox_offset {vox} is not a byte offset")));
    }
    // As the nifti crate reads a .nii: the data starts at vox_offset, and
    // right after the header when vox_offset is smaller.
    let offset = (vox as usize).max(NIFTI1_HEADER + 4);
    let slope = f32_at(112);
    let scale = (slope != 0.0).then(|| (slope, f32_at(116)));
    let voxel = std::array::from_fn(|a| {
        let v = f64::from(f32_at(80 + 4 * a));
        if v.is_finite() && v > 0.0 {
            v
        } else {
            1.0
        }
    });
    let unit = match h[123] & 7 {
        1 => Some("meter"),
        2 => Some("millimeter"),
        3 => Some("micrometer"),
        _ => None,
    };
    Ok(NiftiHeader { dims, ty, big_endian, offset, scale, voxel, unit })
}
