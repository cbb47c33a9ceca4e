//! The sample types a volume file stores (raw: u8, u16, f32; NIfTI-1: the
//! real scalars) and their decoding to the f32 samples the runtime uses,
//! as the in-memory loaders convert them.

use super::RawType;

/// The stored sample types (raw files: u8, u16, f32; NIfTI: the real scalars).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Sample {
    U8,
    I8,
    U16,
    I16,
    U32,
    I32,
    U64,
    I64,
    F32,
    F64,
}

impl Sample {
    pub(super) fn size(self) -> usize {
        match self {
            Sample::U8 | Sample::I8 => 1,
            Sample::U16 | Sample::I16 => 2,
            Sample::U32 | Sample::I32 | Sample::F32 => 4,
            Sample::U64 | Sample::I64 | Sample::F64 => 8,
        }
    }

    pub(super) fn name(self) -> &'static str {
        match self {
            Sample::U8 => "uint8",
            Sample::I8 => "int8",
            Sample::U16 => "uint16",
            Sample::I16 => "int16",
            Sample::U32 => "uint32",
            Sample::I32 => "int32",
            Sample::U64 => "uint64",
            Sample::I64 => "int64",
            Sample::F32 => "float32",
            Sample::F64 => "float64",
        }
    }

    pub(super) fn from_raw(ty: RawType) -> Sample {
        match ty {
            RawType::U8 => Sample::U8,
            RawType::U16 => Sample::U16,
            RawType::F32 => Sample::F32,
        }
    }
}

/// Decodes `dst.len()` samples of `ty` from `src` (exactly that many bytes)
/// to f32 as the loaders do: `as f32`, then `v * slope + inter` if scaled.
pub(super) fn decode(ty: Sample, big_endian: bool, scale: Option<(f32, f32)>, src: &[u8], dst: &mut [f32]) {
    macro_rules! conv {
        ($t:ty, $n:expr) => {
            for (d, c) in dst.iter_mut().zip(src.chunks_exact($n)) {
                let b: [u8; $n] = c.try_into().unwrap_or([0; $n]);
                *d = if big_endian { <$t>::from_be_bytes(b) } else { <$t>::from_le_bytes(b) } as f32;
            }
        };
    }
    match ty {
        Sample::U8 => dst.iter_mut().zip(src).for_each(|(d, &b)| *d = b as f32),
        Sample::I8 => dst.iter_mut().zip(src).for_each(|(d, &b)| *d = b as i8 as f32),
        Sample::U16 => conv!(u16, 2),
        Sample::I16 => conv!(i16, 2),
        Sample::U32 => conv!(u32, 4),
        Sample::I32 => conv!(i32, 4),
        Sample::U64 => conv!(u64, 8),
        Sample::I64 => conv!(i64, 8),
        Sample::F32 => conv!(f32, 4),
        Sample::F64 => conv!(f64, 8),
    }
    if let Some((slope, inter)) = scale {
        for d in dst.iter_mut() {
            *d = *d * slope + inter;
        }
    }
}
