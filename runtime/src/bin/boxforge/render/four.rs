//! `boxforge render` with a 4D filter: an isosurface of a time series at
//! any time t (`--time`), or an animation of `--frames` PNGs over the
//! series, by evaluating the 4D spline at (x, y, z, t) on the device
//! (`boxforge_runtime::render::four`).

use super::RenderArgs;
use crate::common::{parse_view, Failure};
use crate::request;
use boxforge::derive::Derivation;
use boxforge::emit::Layout;
use boxforge::spec::lattice::Lattice;
use boxforge_runtime::gpu::Gpu;
use boxforge_runtime::render::dvr::transfer::TransferFunction;
use boxforge_runtime::render::four::{FourIsoOptions, FourIsoRenderer};
use boxforge_runtime::render::Camera;
use boxforge_runtime::volume::{parse_raw_spec, LatticeVolume4, VolumeSeries};
use std::path::{Path, PathBuf};

/// The samples `--volume` names on the filter's lattice, with the lattice
/// units per frame and the number of frames: `ml-drift:N,F` (the drifting
/// Marschner-Lobb signal, N^3 samples in F frames, sampled on the lattice at
/// that count), a `.nii`/`.nii.gz` with a fourth dimension, or a folder of
/// numbered raw frames with `--raw nx,ny,nz,type` (Cartesian series: as they
/// are on Z^4, else their lattice subset or, with --resample, resampled at a
/// matched count).
fn load_volume(a: &RenderArgs, lattice: &Lattice) -> Result<(LatticeVolume4, f64, usize), Failure> {
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
    let series = if path.is_dir() {
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

/// `out.png` -> `out-0003.png`.
fn numbered(out: &Path, k: usize) -> PathBuf {
    let stem = out.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_else(|| "frame".into());
    out.with_file_name(format!("{stem}-{k:04}.png"))
}

pub(super) fn run(a: &RenderArgs, d: &Derivation) -> Result<(), Failure> {
    let (az, el) = parse_view(&a.view)?;
    request::check_render_numbers(a.size, a.step, a.iso, az, el)?;
    request::check_output_file(&a.out, "--out")?;
    // What the 4D renderer does not do yet, refused by name.
    let refuse = |flag: &str| -> Result<(), Failure> {
        Err(Failure(format!(
            "{flag} is not offered for 4D filters yet (orthographic isosurfaces and DVR, in core): drop it"
        )))
    };
    request::check_render_mode(a.mode.name(), a.tf.as_deref(), a.no_preintegration)?;
    let dvr = a.mode == super::ModeArg::Dvr;
    if dvr && (a.no_preintegration || a.tf_curvature) {
        return refuse("--no-preintegration/--tf-curvature");
    }
    if a.gpu_budget.is_some() {
        return refuse("--gpu-budget");
    }
    let exact = a.hit != super::HitArg::Step;
    if exact && dvr {
        return Err(Failure("--hit exact finds isosurfaces; DVR samples fixed steps: drop --hit or --mode dvr".into()));
    }
    if a.shade != super::ShadeArg::Phong {
        return refuse("--shade");
    }
    if a.cache != super::CacheArg::None || a.renderer != super::RendererArg::Raycast {
        return refuse("--cache/--renderer");
    }
    if a.perspective {
        return refuse("--perspective");
    }
    let layout = Layout::from(a.layout);
    if layout.is_bricked() {
        return Err(Failure(format!(
            "--layout {}: 4D samples are a storage buffer; use --layout embedded or packed",
            layout.name()
        )));
    }
    let (vol, per_frame, frames) = load_volume(a, &d.filter.lattice)?;
    let last = (frames - 1) as f32;
    let times: Vec<f32> = match (a.time, a.frames) {
        (Some(_), Some(_)) => return Err(Failure("--time draws one frame and --frames an animation: give one".into())),
        (Some(t), None) if !(0.0..=last).contains(&t) => {
            return Err(Failure(format!("--time {t}: the series has frames 0 to {last}; give a time in that range")))
        }
        (Some(t), None) => vec![t],
        (None, Some(0)) => return Err(Failure("--frames 0: give at least 1 frame".into())),
        (None, Some(n)) => (0..n).map(|k| if n == 1 { 0.0 } else { last * k as f32 / (n - 1) as f32 }).collect(),
        (None, None) => vec![0.5 * last],
    };
    let gpu = Gpu::new(a.adapter.as_deref()).map_err(|e| Failure(e.to_string()))?;
    let renderer = FourIsoRenderer::new(&gpu, d, &vol, layout).map_err(|e| Failure(e.to_string()))?;
    let o = FourIsoOptions {
        width: a.size,
        height: a.size,
        iso: a.iso,
        step: a.step,
        camera: Camera { azimuth: az, elevation: el, perspective: false },
        exact,
    };
    // DVR: --tf, or a ramp over the samples' range.
    let tf = if dvr {
        let f = match &a.tf {
            Some(name) => TransferFunction::load(name).map_err(|e| Failure(format!("--tf {e}")))?,
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
        boxforge_runtime::render::iso::write_png(&path, a.size, a.size, &rgba)
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
