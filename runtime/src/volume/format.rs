//! Compact sample formats: u8, u16 (normalized), f16 and f32 samples stored
//! as such on the device, with the affine map that turns a stored sample
//! back into a value ([`SampleMap`], applied once per evaluation by the
//! emitted module).

use super::VolumeError;
use boxforge::emit::SampleMap;

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
    /// 8-bit normalized (R8Unorm): 256 levels over the data range.
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

    /// The texture format (every one reads as `texture_3d<f32>` in WGSL).
    pub fn texture_format(self) -> wgpu::TextureFormat {
        match self {
            SampleFormat::F32 => wgpu::TextureFormat::R32Float,
            SampleFormat::F16 => wgpu::TextureFormat::R16Float,
            SampleFormat::U16 => wgpu::TextureFormat::R16Unorm,
            SampleFormat::U8 => wgpu::TextureFormat::R8Unorm,
        }
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
        // Unorm texels read as k / (levels - 1) in [0, 1]: the map spans the range.
        let span = hi - lo;
        if span > 0.0 && span.is_finite() {
            SampleMap { scale: span, offset: lo }
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
                message: format!("the data holds {v}, which a compact format cannot store; use --format f32"),
            });
        }
        if self == SampleFormat::F16 {
            if let Some(v) = values.iter().find(|v| v.abs() > 65504.0) {
                return Err(VolumeError::Format {
                    format: self.name(),
                    message: format!("{v} is past f16's largest value 65504; use --format f32, u16 or u8"),
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
                values.iter().map(|&v| (((v - map.offset) / map.scale).clamp(0.0, 1.0) * 255.0).round() as u8).collect()
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
            SampleFormat::U8 => bytes.iter().map(|&b| map.offset + map.scale * (b as f32 / 255.0)).collect(),
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
    fn integer_data_is_exact_in_u8() {
        let values: Vec<f32> = (0..=255).map(|i| i as f32).collect();
        let map = SampleFormat::U8.map_for(0.0, 255.0);
        let back = SampleFormat::U8.decode(&SampleFormat::U8.encode(&values, map).unwrap(), map);
        for (a, b) in values.iter().zip(&back) {
            assert!((a - b).abs() < 1e-4, "{a} -> {b}");
        }
    }
}
