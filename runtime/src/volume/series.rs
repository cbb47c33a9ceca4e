//! Time series of Cartesian volumes, the data of time-varying (4D)
//! rendering: a `.nii`/`.nii.gz` with a fourth dimension, a folder of
//! numbered raw files, or the drifting Marschner-Lobb space-time test
//! signal (analytic, so a reconstruction's error can be measured); each
//! frame a [`Volume`], and the linear blend of two frames, what a viewer
//! that interpolates between its 3D frames would show at a time between
//! samples.

#[cfg(feature = "nifti")]
use super::error::check_finite;
use super::error::checked_count;
use super::raw::RawType;
use super::synthetic::{ML_ALPHA, ML_FM};
use super::{Volume, VolumeError};
use std::f64::consts::PI;
use std::path::{Path, PathBuf};

/// Frames of one 3D Cartesian grid, x fastest, then y, z and the frame:
/// value(i, j, k, f) = data[i + nx (j + ny (k + nz f))].
#[derive(Clone, Debug, PartialEq)]
pub struct VolumeSeries {
    /// Samples per axis of a frame, then the number of frames.
    pub dims: [usize; 4],
    /// The samples, x fastest, frame slowest.
    pub data: Vec<f32>,
}

impl VolumeSeries {
    /// A series from dims and data; errors on a zero dim or a length mismatch.
    pub fn new(dims: [usize; 4], data: Vec<f32>) -> Result<VolumeSeries, VolumeError> {
        let per_frame = checked_count([dims[0], dims[1], dims[2]])?;
        if dims[3] == 0 {
            return Err(VolumeError::SeriesEmpty);
        }
        let expected = per_frame
            .checked_mul(dims[3])
            .ok_or(VolumeError::SeriesTooLarge { dims: [dims[0], dims[1], dims[2]], frames: dims[3] })?;
        if data.len() != expected {
            return Err(VolumeError::SeriesLength {
                dims: [dims[0], dims[1], dims[2]],
                frames: dims[3],
                len: data.len(),
                expected,
            });
        }
        Ok(VolumeSeries { dims, data })
    }

    /// Frames of equal dims, in order.
    pub fn from_frames(frames: Vec<Volume>) -> Result<VolumeSeries, VolumeError> {
        let first = frames.first().ok_or(VolumeError::SeriesEmpty)?.dims;
        if let Some((k, f)) = frames.iter().enumerate().find(|(_, f)| f.dims != first) {
            return Err(VolumeError::SeriesFrameDims { frame: k, dims: f.dims, first });
        }
        let n = frames.len();
        let data = frames.into_iter().flat_map(|f| f.data).collect();
        VolumeSeries::new([first[0], first[1], first[2], n], data)
    }

    /// Frames in the series.
    pub fn frames(&self) -> usize {
        self.dims[3]
    }

    /// Frame `k` as a volume (None past the last).
    pub fn frame(&self, k: usize) -> Option<Volume> {
        let n = self.dims[0] * self.dims[1] * self.dims[2];
        let data = self.data.get(k * n..(k + 1) * n)?.to_vec();
        Some(Volume { dims: [self.dims[0], self.dims[1], self.dims[2]], data })
    }

    /// The linear blend of the frames around time `t` (in frames, clamped
    /// to [0, frames - 1]): (1 - f) frame(k) + f frame(k + 1), k = floor(t).
    pub fn blend(&self, t: f64) -> Volume {
        let last = (self.frames() - 1) as f64;
        let t = if t.is_nan() { 0.0 } else { t.clamp(0.0, last) };
        let k = (t.floor() as usize).min(self.frames() - 1);
        let f = (t - k as f64) as f32;
        let a = self.frame(k).expect("k is a frame");
        let b = self.frame((k + 1).min(self.frames() - 1)).expect("a frame");
        let data = a.data.iter().zip(&b.data).map(|(x, y)| (1.0 - f) * x + f * y).collect();
        Volume { dims: a.dims, data }
    }

    /// Reads a NIfTI-1 file of rank 3 (one frame) or 4 (x, y, z, time;
    /// trailing singleton dimensions dropped), with the checks of
    /// [`Volume::load_nifti`].
    #[cfg(feature = "nifti")]
    pub fn load_nifti(path: &Path) -> Result<VolumeSeries, VolumeError> {
        use nifti::{IntoNdArray, NiftiObject, NiftiVolume, ReaderOptions};
        let fail = |message: String| VolumeError::Nifti { path: path.to_path_buf(), message };
        let obj = ReaderOptions::new().read_file(path).map_err(|e| fail(e.to_string()))?;
        let shape: Vec<usize> = obj.volume().dim().iter().map(|&d| d as usize).collect();
        if shape.len() < 3 || shape.get(4..).is_some_and(|rest| rest.iter().any(|&d| d != 1)) {
            return Err(VolumeError::SeriesRank { path: path.to_path_buf(), shape });
        }
        let dims = [shape[0], shape[1], shape[2], shape.get(3).copied().unwrap_or(1)];
        let array = obj.into_volume().into_ndarray::<f32>().map_err(|e| fail(e.to_string()))?;
        // Reversed axes: x fastest, then y, z, t, whatever the memory order.
        let data: Vec<f32> = array.t().iter().copied().collect();
        check_finite(path, [dims[0], dims[1], dims[2] * dims[3]], &data)?;
        VolumeSeries::new(dims, data)
    }

    /// Reads a folder of raw files, one frame each, all `dims` samples of
    /// `ty`: the files whose names end in `.raw`, in the order of the last
    /// number in their names (frame_2.raw before frame_10.raw). Refuses a
    /// folder without such files, two files with the same number, and a
    /// file of the wrong length, naming it.
    pub fn load_raw_folder(dir: &Path, dims: [usize; 3], ty: RawType) -> Result<VolumeSeries, VolumeError> {
        let io = |source| VolumeError::Io { path: dir.to_path_buf(), source };
        let mut files: Vec<(u64, PathBuf)> = Vec::new();
        for entry in std::fs::read_dir(dir).map_err(io)? {
            let path = entry.map_err(io)?.path();
            if path.extension().and_then(|e| e.to_str()) != Some("raw") {
                continue;
            }
            let stem = path.file_stem().and_then(|s| s.to_str()).unwrap_or_default().to_string();
            let Some(number) = frame_number(&stem) else {
                return Err(VolumeError::SeriesFrameName { path });
            };
            files.push((number, path));
        }
        if files.is_empty() {
            return Err(VolumeError::SeriesNoFrames { dir: dir.to_path_buf() });
        }
        files.sort();
        if let Some(w) = files.windows(2).find(|w| w[0].0 == w[1].0) {
            return Err(VolumeError::SeriesDuplicate { first: w[0].1.clone(), second: w[1].1.clone(), frame: w[0].0 });
        }
        let frames = files.iter().map(|(_, p)| Volume::load_raw(p, dims, ty)).collect::<Result<Vec<_>, _>>()?;
        VolumeSeries::from_frames(frames)
    }

    /// The drifting Marschner-Lobb signal ([`marschner_lobb_drift`]) sampled
    /// at x = -1 + 2 j / (n - 1) per spatial axis and t = f / (frames - 1).
    pub fn marschner_lobb_drift(dims: [usize; 4]) -> Result<VolumeSeries, VolumeError> {
        checked_count([dims[0], dims[1], dims[2]])?;
        let at = |j: usize, n: usize| if n > 1 { j as f64 / (n - 1) as f64 } else { 0.0 };
        let mut data = Vec::with_capacity(dims.iter().product());
        for f in 0..dims[3] {
            for k in 0..dims[2] {
                for j in 0..dims[1] {
                    for i in 0..dims[0] {
                        let idx = [i, j, k];
                        let p = [0, 1, 2].map(|a| -1.0 + 2.0 * at(idx[a], dims[a]));
                        data.push(marschner_lobb_drift([p[0], p[1], p[2], at(f, dims[3])]) as f32);
                    }
                }
            }
        }
        VolumeSeries::new(dims, data)
    }
}

/// The last run of digits in a file stem, as a number.
fn frame_number(stem: &str) -> Option<u64> {
    let end = stem.rfind(|c: char| c.is_ascii_digit())? + 1;
    let start = stem[..end].rfind(|c: char| !c.is_ascii_digit()).map_or(0, |i| i + 1);
    stem[start..end].parse().ok()
}

/// The frequency of [`marschner_lobb_drift`]'s ripples at time t: the
/// Marschner-Lobb f_M = 6 at t = 0, rising linearly to 9 at t = 1.
pub fn ml_drift_frequency(t: f64) -> f64 {
    ML_FM * (1.0 + 0.5 * t)
}

/// A space-time test signal: Marschner and Lobb's function of (x, y, z) in
/// [-1, 1]^3 whose ripple frequency drifts with t in [0, 1]
/// ([`ml_drift_frequency`]), so that frames sampled in t differ in more than
/// their values and a blend of two frames is not the signal between them.
pub fn marschner_lobb_drift(p: [f64; 4]) -> f64 {
    let [x, y, z, t] = p;
    let r = (x * x + y * y).sqrt();
    let rho_r = (2.0 * PI * ml_drift_frequency(t) * (PI * r / 2.0).cos()).cos();
    (1.0 - (PI * z / 2.0).sin() + ML_ALPHA * (1.0 + rho_r)) / (2.0 * (1.0 + ML_ALPHA))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::volume::marschner_lobb;

    fn temp_dir(tag: &str) -> PathBuf {
        let d = std::env::temp_dir().join(format!("boxforge-series-{tag}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        std::fs::create_dir_all(&d).unwrap();
        d
    }

    #[test]
    fn the_drifting_signal_starts_as_marschner_lobb_and_its_frames_differ() {
        for p in [[0.3, -0.2, 0.5], [0.0, 0.0, 0.0], [-0.9, 0.7, -0.1]] {
            let a = marschner_lobb_drift([p[0], p[1], p[2], 0.0]);
            assert!((a - marschner_lobb(p)).abs() < 1e-12, "t = 0 is Marschner-Lobb");
        }
        let s = VolumeSeries::marschner_lobb_drift([9, 9, 9, 3]).unwrap();
        assert_eq!(s.data.len(), 9 * 9 * 9 * 3);
        let (f0, f2) = (s.frame(0).unwrap(), s.frame(2).unwrap());
        assert!(f0.data.iter().zip(&f2.data).any(|(a, b)| (a - b).abs() > 0.05), "the ripples move");
        // The middle frame is the signal at t = 1/2, not the mean of its neighbours.
        let mid = s.frame(1).unwrap();
        let blend = s.blend(1.0);
        assert_eq!(blend.data, mid.data, "a whole frame time is that frame");
        let between = s.blend(0.5);
        let exact = VolumeSeries::marschner_lobb_drift([9, 9, 9, 5]).unwrap().frame(1).unwrap();
        let err = between.data.iter().zip(&exact.data).map(|(a, b)| (a - b).abs()).fold(0.0, f32::max);
        assert!(err > 0.05, "a blend of frames is not the signal between them ({err})");
    }

    #[test]
    fn a_folder_of_numbered_raw_frames_loads_in_numeric_order() {
        let dir = temp_dir("folder");
        for (k, name) in [(10, "scan_10.raw"), (2, "scan_2.raw"), (1, "scan_1.raw")] {
            std::fs::write(dir.join(name), vec![k as u8; 8]).unwrap();
        }
        std::fs::write(dir.join("notes.txt"), b"ignored").unwrap();
        let s = VolumeSeries::load_raw_folder(&dir, [2, 2, 2], RawType::U8).unwrap();
        assert_eq!(s.dims, [2, 2, 2, 3]);
        let firsts: Vec<f32> = (0..3).map(|k| s.frame(k).unwrap().data[0]).collect();
        assert_eq!(firsts, [1.0, 2.0, 10.0]);
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn bad_series_are_refused_with_the_file_and_the_fix() {
        let dir = temp_dir("bad");
        let e = VolumeSeries::load_raw_folder(&dir, [2, 2, 2], RawType::U8).unwrap_err().to_string();
        assert!(e.contains("no .raw files"), "{e}");
        std::fs::write(dir.join("f_0.raw"), [0u8; 8]).unwrap();
        std::fs::write(dir.join("f_1.raw"), [0u8; 7]).unwrap();
        let e = VolumeSeries::load_raw_folder(&dir, [2, 2, 2], RawType::U8).unwrap_err().to_string();
        assert!(e.contains("f_1.raw") && e.contains("7 bytes"), "{e}");
        std::fs::write(dir.join("f_1.raw"), [0u8; 8]).unwrap();
        std::fs::write(dir.join("g_01.raw"), [0u8; 8]).unwrap();
        let e = VolumeSeries::load_raw_folder(&dir, [2, 2, 2], RawType::U8).unwrap_err().to_string();
        assert!(e.contains("both claim frame 1"), "{e}");
        std::fs::remove_file(dir.join("g_01.raw")).unwrap();
        std::fs::write(dir.join("nonumber.raw"), [0u8; 8]).unwrap();
        let e = VolumeSeries::load_raw_folder(&dir, [2, 2, 2], RawType::U8).unwrap_err().to_string();
        assert!(e.contains("no frame number"), "{e}");
        let frames = vec![Volume::new([2, 2, 2], vec![0.0; 8]).unwrap(), Volume::new([2, 2, 1], vec![0.0; 4]).unwrap()];
        let e = VolumeSeries::from_frames(frames).unwrap_err().to_string();
        assert!(e.contains("frame 1 is 2x2x1"), "{e}");
        assert!(VolumeSeries::new([2, 2, 2, 2], vec![0.0; 15]).is_err());
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[cfg(feature = "nifti")]
    #[test]
    fn a_four_d_nifti_loads_frame_by_frame_x_fastest() {
        let dir = temp_dir("nifti");
        let path = dir.join("series.nii.gz");
        // value = x + 10 y + 100 z + 1000 t, indexed (x, y, z, t) as NIfTI is.
        let a = ndarray::Array4::from_shape_fn((3, 2, 2, 4), |(x, y, z, t)| (x + 10 * y + 100 * z + 1000 * t) as f32);
        nifti::writer::WriterOptions::new(&path).write_nifti(&a).unwrap();
        let s = VolumeSeries::load_nifti(&path).unwrap();
        assert_eq!(s.dims, [3, 2, 2, 4]);
        let f = s.frame(2).unwrap();
        assert_eq!(f.get(1, 1, 0), 2011.0);
        assert_eq!(f.get(2, 0, 1), 2102.0);
        // A 5-D file with a non-singleton fifth dimension is refused.
        let bad = dir.join("five.nii");
        let five = ndarray::Array5::from_shape_fn((2, 2, 2, 2, 2), |_| 0f32);
        nifti::writer::WriterOptions::new(&bad).write_nifti(&five).unwrap();
        let e = VolumeSeries::load_nifti(&bad).unwrap_err().to_string();
        assert!(e.contains("5-D") && e.contains("(x, y, z, t)"), "{e}");
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn frame_numbers_are_the_last_digits_of_the_name() {
        assert_eq!(frame_number("frame_007"), Some(7));
        assert_eq!(frame_number("t12_echo3"), Some(3));
        assert_eq!(frame_number("scan"), None);
        assert_eq!(frame_number("42"), Some(42));
    }
}
