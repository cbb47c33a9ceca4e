//! Headerless raw volume files: the sample types, the NX,NY,NZ,TYPE spec and
//! loading into a Cartesian [`Volume`].

use super::error::{check_finite, checked_count};
use super::{Volume, VolumeError};
use std::path::Path;

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

impl Volume {
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
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::volume::testutil::Temp;

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
}
