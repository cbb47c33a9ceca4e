//! `boxforge render` with a 4D filter: an isosurface of a time series at
//! any time t (`--time`), or an animation of `--frames` PNGs over the
//! series, by evaluating the 4D spline at (x, y, z, t) on the device
//! (`boxforge_runtime::render::four`).

use super::checked::{FourRequest, Source, Times};
use crate::common::Failure;
use crate::request::TfChoice;
use boxforge::derive::Derivation;
use boxforge::spec::lattice::Lattice;
use boxforge_runtime::gpu::Gpu;
use boxforge_runtime::render::dvr::transfer::TransferFunction;
use boxforge_runtime::render::four::{FourIsoOptions, FourIsoRenderer};
use boxforge_runtime::render::Camera;
use boxforge_runtime::volume::zarr::{OmeZarr, Selection, ZarrVolume};
use boxforge_runtime::volume::{parse_raw_spec, LatticeVolume4, VolumeSeries};
use std::path::{Path, PathBuf};

/// The samples `--volume` names on the filter's lattice, with the lattice
/// units per frame and the number of frames: `ml-drift:N,F` (the drifting
/// Marschner-Lobb signal, N^3 samples in F frames, sampled on the lattice at
/// that count), a `.nii`/`.nii.gz` with a fourth dimension, or a folder of
/// numbered raw frames with `--raw nx,ny,nz,type`, or the time points of an
/// OME-Zarr image's level and channel (Cartesian series: as they
/// are on Z^4, else their lattice subset or, with --resample, resampled at a
/// matched count).
fn load_volume(a: &Source, lattice: &Lattice) -> Result<(LatticeVolume4, f64, usize), Failure> {
    let volume = a.volume.as_str();
    if let Some(spec) = volume.strip_prefix("ml-drift:") {
        let bad =
            || Failure(format!("--volume {volume}: write ml-drift:N,F (N^3 samples per frame, F frames; N, F >= 2)"));
        let (n, f) = spec.split_once(',').ok_or_else(bad)?;
        let (n, f): (usize, usize) = (n.trim().parse().map_err(|_| bad())?, f.trim().parse().map_err(|_| bad())?);
        if n < 2 || f < 2 || n > 512 || f > 4096 {
            return Err(bad());
        }
        let (vol, per_frame) =
            LatticeVolume4::marschner_lobb_drift(lattice, n, f).map_err(|e| Failure(e.to_string()))?;
        return Ok((vol, per_frame, f));
    }
    let path = Path::new(volume);
    let series = if let Some(s) = a.zarr {
        zarr_series(path, s)?
    } else if path.is_dir() {
        let spec = a.raw.as_deref().ok_or_else(|| {
            Failure(format!("--volume {volume} is a folder of raw frames: give their format with --raw nx,ny,nz,type"))
        })?;
        let (dims, ty) = parse_raw_spec(spec).map_err(|e| Failure(format!("--raw {e}")))?;
        VolumeSeries::load_raw_folder(path, dims, ty).map_err(|e| Failure(e.to_string()))?
    } else {
        VolumeSeries::load_nifti(path).map_err(|e| Failure(e.to_string()))?
    };
    let frames = series.frames();
    let err = |e: boxforge_runtime::volume::VolumeError| Failure(e.to_string());
    Ok(if lattice.name == "z4" {
        (LatticeVolume4::from_series(&series), 1.0, frames)
    } else if a.resample {
        let (vol, per_frame) = LatticeVolume4::resample(lattice, &series).map_err(err)?;
        (vol, per_frame, frames)
    } else {
        (LatticeVolume4::subset(lattice, &series).map_err(err)?, 1.0, frames)
    })
}

/// Every time point of an OME-Zarr image's level and channel, as frames.
fn zarr_series(path: &Path, s: Selection) -> Result<VolumeSeries, Failure> {
    let fail = |e: &dyn std::fmt::Display| Failure(e.to_string());
    // Frames are read whole as Cartesian volumes; the 4D lattice takes them after.
    let cc = Lattice::builtin("cc").map_err(|e| fail(&e))?;
    let image = OmeZarr::open(path).map_err(|e| fail(&e))?;
    if image.times() < 2 {
        return Err(Failure(format!(
            "{}: a 4D filter draws a time series, but the image has {} time point (no t axis with 2 or more): draw it with a 3D filter",
            path.display(),
            image.times()
        )));
    }
    let frames = (0..image.times())
        .map(|time| ZarrVolume::new(&image, Selection { time, ..s }, &cc)?.to_volume())
        .collect::<Result<Vec<_>, _>>()
        .map_err(|e| fail(&e))?;
    VolumeSeries::from_frames(frames).map_err(|e| fail(&e))
}

/// `out.png` -> `out-0003.png`.
fn numbered(out: &Path, k: usize) -> PathBuf {
    let stem = out.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_else(|| "frame".into());
    out.with_file_name(format!("{stem}-{k:04}.png"))
}

/// The work of a checked 4D `render`: the filter derived, the series
/// loaded, the frames drawn and written.
pub(super) fn run(r: &FourRequest) -> Result<(), Failure> {
    let d = &Derivation::new(&r.filter)?;
    let (a, layout, size) = (&r.frame, r.layout, r.frame.size);
    // DVR: --tf loaded before the data (a ramp over the samples' range without one).
    let named = match &r.tf {
        Some(TfChoice::Named(name)) => Some(TransferFunction::load(name).map_err(|e| Failure(format!("--tf {e}")))?),
        _ => None,
    };
    let (vol, per_frame, frames) = load_volume(&r.source, &d.filter.lattice)?;
    let last = (frames - 1) as f32;
    let times: Vec<f32> = match r.times {
        Times::At(t) if !(0.0..=last).contains(&t) => {
            return Err(Failure(format!("--time {t}: the series has frames 0 to {last}; give a time in that range")))
        }
        Times::At(t) => vec![t],
        Times::Frames(n) => (0..n).map(|k| if n == 1 { 0.0 } else { last * k as f32 / (n - 1) as f32 }).collect(),
        Times::Middle => vec![0.5 * last],
    };
    let gpu = Gpu::new(a.adapter.as_deref()).map_err(|e| Failure(e.to_string()))?;
    let renderer = FourIsoRenderer::new(&gpu, d, &vol, layout).map_err(|e| Failure(e.to_string()))?;
    let o = FourIsoOptions {
        width: size,
        height: size,
        iso: a.iso,
        step: a.step,
        camera: Camera { azimuth: a.azimuth, elevation: a.elevation, perspective: false },
        exact: r.exact,
    };
    // DVR: --tf, or a ramp over the samples' range.
    let tf = if r.tf.is_some() {
        let f = match named {
            Some(f) => f,
            None => {
                let (lo, hi) =
                    vol.data.iter().fold((f32::INFINITY, f32::NEG_INFINITY), |(l, h), &v| (l.min(v), h.max(v)));
                TransferFunction::ramp(lo as f64, (hi as f64).max(lo as f64 + 1e-6))
            }
        };
        Some(f.table())
    } else {
        None
    };
    let bar = boxforge_runtime::progress::bar(times.len() as u64, "frames");
    for (k, &t) in times.iter().enumerate() {
        // Frames of the series to lattice units of the time axis.
        let w = (t as f64 * per_frame) as f32;
        let rgba = match &tf {
            Some(tf) => renderer.render_dvr(w, &o, tf),
            None => renderer.render(w, &o),
        }
        .map_err(|e| Failure(e.to_string()))?;
        let path = if times.len() == 1 { a.out.clone() } else { numbered(&a.out, k) };
        boxforge_runtime::render::iso::write_png(&path, size, size, &rgba)
            .map_err(|e| Failure(format!("cannot write {}: {e}", path.display())))?;
        bar.inc(1);
        if times.len() == 1 {
            outln!("{} at t = {t} (frames 0..{last}) on {}: {}", d.filter.name, gpu.describe(), path.display());
        }
    }
    bar.finish_and_clear();
    if times.len() > 1 {
        outln!(
            "{} frames of {} over t = 0..{last} on {}: {} .. {}",
            times.len(),
            d.filter.name,
            gpu.describe(),
            numbered(&a.out, 0).display(),
            numbered(&a.out, times.len() - 1).display()
        );
    }
    Ok(())
}
