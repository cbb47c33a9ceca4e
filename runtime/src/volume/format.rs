//! Compact sample formats: u8, u16 (normalized), f16 and f32 samples stored
//! as such on the device, with the affine map that turns a stored sample
//! back into a value ([`SampleMap`], applied once per evaluation by the
//! emitted module).

use super::VolumeError;
use boxforge::emit::{SampleMap, Texels};

/// How samples are stored on the device.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum SampleFormat {
    /// 32-bit float (R32Float), exact.
    #[default]
    F32,
    /// 16-bit float (R16Float): 11 significant bits, |v| up to 65504.
    F16,
    /// 16-bit normalized (R16Unorm; needs TEXTURE_FORMAT_16BIT_NORM): 65536
    /// levels over the data range.
    U16,
    /// 8 bits: 256 levels over the data range, four samples per R32Uint
    /// texel along x (the module reads them as [`Texels::U8x4`]: on
    /// llvmpipe an 8-bit texel fetch loads lane by lane, a 32-bit one is a
    /// vector gather).
    U8,
}

impl SampleFormat {
    /// Every format, widest first.
    pub const ALL: [SampleFormat; 4] = [SampleFormat::F32, SampleFormat::F16, SampleFormat::U16, SampleFormat::U8];

    /// The name used on the command line.
    pub fn name(self) -> &'static str {
        match self {
            SampleFormat::F32 => "f32",
            SampleFormat::F16 => "f16",
            SampleFormat::U16 => "u16",
            SampleFormat::U8 => "u8",
        }
    }

    /// The format named `s`; None for any other string.
    pub fn parse(s: &str) -> Option<SampleFormat> {
        SampleFormat::ALL.into_iter().find(|f| f.name() == s)
    }

    /// Bytes per stored sample.
    pub fn bytes(self) -> usize {
        match self {
            SampleFormat::F32 => 4,
            SampleFormat::F16 | SampleFormat::U16 => 2,
            SampleFormat::U8 => 1,
        }
    }

    /// The texture format (all but u8 read as `texture_3d<f32>` in WGSL;
    /// u8 as `texture_3d<u32>`, four samples a texel).
    pub fn texture_format(self) -> wgpu::TextureFormat {
        match self {
            SampleFormat::F32 => wgpu::TextureFormat::R32Float,
            SampleFormat::F16 => wgpu::TextureFormat::R16Float,
            SampleFormat::U16 => wgpu::TextureFormat::R16Unorm,
            SampleFormat::U8 => wgpu::TextureFormat::R32Uint,
        }
    }

    /// What the emitted module's texels hold for this format.
    pub fn texels(self) -> Texels {
        match self {
            SampleFormat::U8 => Texels::U8x4,
            _ => Texels::Float,
        }
    }

    /// Samples per texel along x (4 for u8, 1 otherwise).
    pub fn per_texel(self) -> usize {
        match self.texels() {
            Texels::U8x4 => 4,
            Texels::Float => 1,
        }
    }

    /// The texture extent holding `size` samples per axis.
    pub fn texture_size(self, size: [usize; 3]) -> [u32; 3] {
        [size[0].div_ceil(self.per_texel()) as u32, size[1] as u32, size[2] as u32]
    }

    /// Bytes of one texture row holding `width` samples.
    pub fn row_bytes(self, width: usize) -> usize {
        width.next_multiple_of(self.per_texel()) * self.bytes()
    }

    /// [`SampleFormat::encode`] of `values` (rows of `width` samples, x
    /// fastest), laid out for a texture of [`SampleFormat::texture_size`].
    pub fn encode_rows(self, values: &[f32], map: SampleMap, width: usize) -> Result<Vec<u8>, VolumeError> {
        Ok(self.texture_rows(self.encode(values, map)?, width))
    }

    /// Stored bytes (rows of `width` samples) laid out for a texture of
    /// [`SampleFormat::texture_size`]: u8 rows padded to whole words by
    /// repeating each row's last sample, so that a fetch clamped to the
    /// texture's last word reads what a fetch clamped to the row's last
    /// sample would. Other formats unchanged.
    fn texture_rows(self, stored: Vec<u8>, width: usize) -> Vec<u8> {
        let (row, padded) = (width * self.bytes(), self.row_bytes(width));
        if row == padded || row == 0 {
            return stored;
        }
        let mut out = Vec::with_capacity(stored.len() / row * padded);
        for r in stored.chunks(row) {
            out.extend_from_slice(r);
            let last = *r.last().expect("rows are not empty");
            out.resize(out.len() + padded - r.len(), last);
        }
        out
    }

    /// The largest error of one stored sample against its value, for data in
    /// [lo, hi]: half a level for the normalized formats, half an f16 ulp at
    /// the largest magnitude for f16, 0 for f32. A spline's weights are
    /// non-negative and sum to 1, so this also bounds the error of its values.
    pub fn max_error(self, lo: f32, hi: f32) -> f64 {
        let span = (hi as f64 - lo as f64).max(0.0);
        match self {
            SampleFormat::F32 => 0.0,
            SampleFormat::F16 => {
                let m = lo.abs().max(hi.abs()) as f64;
                if m == 0.0 {
                    0.0
                } else {
                    // 10 fraction bits: half an ulp is 2^(e - 11).
                    2f64.powi(m.log2().floor() as i32 - 11)
                }
            }
            SampleFormat::U16 => span / 65535.0 / 2.0,
            SampleFormat::U8 => span / 255.0 / 2.0,
        }
    }

    /// The map for data in [lo, hi]: normalized formats spread the range over
    /// their levels, float formats store values as they are.
    pub fn map_for(self, lo: f32, hi: f32) -> SampleMap {
        if matches!(self, SampleFormat::F32 | SampleFormat::F16) {
            return SampleMap::IDENTITY;
        }
        // Unorm texels (u16) read as k / (levels - 1) in [0, 1]: the map
        // spans the range; u8 words read as the integer k: a level's step.
        let span = hi - lo;
        let levels = if self == SampleFormat::U8 { 255.0 } else { 1.0 };
        if span > 0.0 && span.is_finite() {
            SampleMap { scale: span / levels, offset: lo }
        } else {
            SampleMap { scale: 1.0, offset: if lo.is_finite() { lo } else { 0.0 } }
        }
    }

    /// Whether the format can hold `values`: compact formats refuse
    /// non-finite samples (a normalized range needs finite ends), f16
    /// refuses magnitudes past 65504 (they would become infinities).
    pub fn check_values(self, values: &[f32]) -> Result<(), VolumeError> {
        if self == SampleFormat::F32 {
            return Ok(());
        }
        if let Some(v) = values.iter().find(|v| !v.is_finite()) {
            return Err(VolumeError::Format {
                format: self.name(),
                message: format!("the data holds {v}, which a compact format cannot store; store it as f32"),
            });
        }
        if self == SampleFormat::F16 {
            if let Some(v) = values.iter().find(|v| v.abs() > 65504.0) {
                return Err(VolumeError::Format {
                    format: self.name(),
                    message: format!("{v} is past f16's largest value 65504; store it as f32, u16 or u8"),
                });
            }
        }
        Ok(())
    }

    /// The stored bytes of `values` (texels, x fastest) with `map`, after
    /// [`SampleFormat::check_values`].
    pub fn encode(self, values: &[f32], map: SampleMap) -> Result<Vec<u8>, VolumeError> {
        self.check_values(values)?;
        Ok(match self {
            SampleFormat::F32 => bytemuck::cast_slice(values).to_vec(),
            SampleFormat::F16 => values.iter().flat_map(|&v| half::f16::from_f32(v).to_le_bytes()).collect(),
            SampleFormat::U16 => {
                let q = |v: f32| (((v - map.offset) / map.scale).clamp(0.0, 1.0) * 65535.0).round() as u16;
                values.iter().flat_map(|&v| q(v).to_le_bytes()).collect()
            }
            SampleFormat::U8 => {
                values.iter().map(|&v| ((v - map.offset) / map.scale).clamp(0.0, 255.0).round() as u8).collect()
            }
        })
    }

    /// The value a stored sample stands for (the device's view of `encode`).
    pub fn decode(self, bytes: &[u8], map: SampleMap) -> Vec<f32> {
        match self {
            SampleFormat::F32 => bytemuck::pod_collect_to_vec(bytes),
            SampleFormat::F16 => bytes.chunks(2).map(|c| half::f16::from_le_bytes([c[0], c[1]]).to_f32()).collect(),
            SampleFormat::U16 => bytes
                .chunks(2)
                .map(|c| map.offset + map.scale * (u16::from_le_bytes([c[0], c[1]]) as f32 / 65535.0))
                .collect(),
            SampleFormat::U8 => bytes.iter().map(|&b| map.offset + map.scale * b as f32).collect(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn each_format_round_trips_within_its_stated_error() {
        let values: Vec<f32> = (0..1000).map(|i| -3.0 + 0.0137 * i as f32 + (i as f32 * 0.7).sin()).collect();
        let (lo, hi) = values.iter().fold((f32::MAX, f32::MIN), |(a, b), &v| (a.min(v), b.max(v)));
        for f in SampleFormat::ALL {
            let map = f.map_for(lo, hi);
            let bytes = f.encode(&values, map).unwrap();
            assert_eq!(bytes.len(), values.len() * f.bytes());
            let back = f.decode(&bytes, map);
            let err = values.iter().zip(&back).map(|(a, b)| (a - b).abs() as f64).fold(0.0, f64::max);
            let bound = f.max_error(lo, hi) * 1.0001 + 1e-6;
            assert!(err <= bound, "{}: error {err} over the stated {bound}", f.name());
            if f != SampleFormat::F32 {
                assert!(err > 0.0, "{}: this data is not exact in the format, a zero error is a bug", f.name());
            }
        }
    }

    #[test]
    fn data_a_format_cannot_hold_is_refused() {
        let e = SampleFormat::F16.encode(&[1.0, 70000.0], SampleMap::IDENTITY).unwrap_err();
        assert!(e.to_string().contains("65504"), "{e}");
        let e = SampleFormat::U8.encode(&[1.0, f32::NAN], SampleMap::IDENTITY).unwrap_err();
        assert!(e.to_string().contains("NaN"), "{e}");
        assert!(SampleFormat::F32.check_values(&[f32::NAN, 1e30]).is_ok(), "f32 stores anything");
    }

    #[test]
    fn u8_rows_are_padded_to_whole_words_with_their_last_sample() {
        let f = SampleFormat::U8;
        assert_eq!(f.texture_size([5, 2, 1]), [2, 2, 1]);
        assert_eq!(f.row_bytes(5), 8);
        let rows = f.texture_rows(vec![1, 2, 3, 4, 5, 6, 7, 8, 9, 10], 5);
        assert_eq!(rows, vec![1, 2, 3, 4, 5, 5, 5, 5, 6, 7, 8, 9, 10, 10, 10, 10]);
        // Whole words and the other formats are left as they are.
        assert_eq!(f.texture_rows(vec![1, 2, 3, 4], 4), vec![1, 2, 3, 4]);
        assert_eq!(SampleFormat::F32.texture_size([5, 2, 1]), [5, 2, 1]);
        assert_eq!(SampleFormat::F16.texture_rows(vec![1, 2, 3, 4], 2), vec![1, 2, 3, 4]);
    }

    #[test]
    fn integer_data_is_exact_in_u8() {
        let values: Vec<f32> = (0..=255).map(|i| i as f32).collect();
        let map = SampleFormat::U8.map_for(0.0, 255.0);
        let back = SampleFormat::U8.decode(&SampleFormat::U8.encode(&values, map).unwrap(), map);
        for (a, b) in values.iter().zip(&back) {
            assert!((a - b).abs() < 1e-4, "{a} -> {b}");
        }
    }
}
