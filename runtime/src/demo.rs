//! `boxforge demo`: the README's main job.

use boxforge::build::output::{generated_files, write_files, ALL_LAYOUTS, ALL_VARIANTS};
use boxforge::derive::Derivation;
use boxforge::emit::{Layout, Variant};
use boxforge_runtime::gpu::Gpu;
use boxforge_runtime::render::{self, valid_box, RenderOptions};
use boxforge_runtime::scene::{self, matched_edge, Conversion};
use boxforge_runtime::upload::DeviceVolume;
use boxforge_runtime::verify::{gpu_eval, Rng};
use boxforge_runtime::volume::{marschner_lobb, ml_position, LatticeVolume, Volume};
use std::path::Path;
use std::time::Instant;

const FILTERS: [&str; 4] = ["cc_tricubic", "bcc7", "bcc8", "fcc6"];
/// Marschner-Lobb budget: about 41^3 samples on every lattice.
const ML_EDGE: f64 = 41.0;
const MNI_FILE: &str = "mni152_t1_1mm.nii.gz";
const MNI_ISO: f32 = 90.0;

struct Row {
    filter: String,
    lattice: String,
    ml_samples: usize,
    rms: f64,
    max_err: f64,
    ml_ms: f64,
    mni_samples: usize,
    mni_ms: f64,
}

pub fn run(out: &Path, size: u32, adapter: Option<&str>) -> Result<(), String> {
    let started = Instant::now();
    let steps = crate::progress::Steps::new();
    steps.step("generating the catalog into shaders-out/");
    // 1. The catalog.
    let command = "boxforge generate --all -o shaders-out";
    for name in boxforge::spec::catalog::names() {
        let d = Derivation::new(&boxforge::spec::catalog::get(name).map_err(|e| e.to_string())?)
            .map_err(|e| e.to_string())?;
        let files = generated_files(&d, command, &ALL_LAYOUTS, &ALL_VARIANTS).map_err(|e| e.to_string())?;
        write_files(Path::new("shaders-out"), &files).map_err(|e| e.to_string())?;
    }
    steps.println(&format!("[demo] catalog generated into shaders-out/ ({:.1} s)", started.elapsed().as_secs_f64()));
    // 2. Device and the real volume.
    let gpu = Gpu::new(adapter).map_err(|e| e.to_string())?;
    steps.println(&format!("[demo] device: {}", gpu.describe()));
    let mni_path = boxforge_runtime::scene::data_file(MNI_FILE)
        .ok_or_else(|| format!("the MNI head data/{MNI_FILE} is missing: run the demo from the repository root"))?;
    let mni = Volume::load_nifti(&mni_path).map_err(|e| format!("{e} (run the demo from the repository root)"))?;
    std::fs::create_dir_all(out).map_err(|e| format!("cannot create {}: {e}", out.display()))?;
    let mut rows = Vec::new();
    let mut images = Vec::new();
    for name in FILTERS {
        steps.step(&format!("{name}: Marschner-Lobb and the MNI head"));
        let d = Derivation::new(&boxforge::spec::catalog::get(name).map_err(|e| e.to_string())?)
            .map_err(|e| e.to_string())?;
        let lat = d.filter.lattice.clone();
        // Marschner-Lobb at a matched sample budget.
        let e = matched_edge(&lat, ML_EDGE.powi(3));
        let ml = LatticeVolume::marschner_lobb(&lat, [e, e, e]).map_err(|e| e.to_string())?;
        let opts = RenderOptions { width: size, height: size, iso: 0.5, step: 0.25, ..RenderOptions::default() };
        let frame = render::render(&gpu, &d, &ml, Layout::Embedded, &opts).map_err(|e| e.to_string())?;
        let ml_png = out.join(format!("ml_{name}.png"));
        render::write_png(&ml_png, frame.width, frame.height, &frame.rgba).map_err(|e| e.to_string())?;
        let (rms, max_err) = ml_error(&gpu, &d, &ml, 100_000)?;
        steps.println(&format!(
            "[demo] {name}: Marschner-Lobb {} samples, {:.1} ms/frame -> {}",
            ml.samples(),
            frame.ms_per_frame,
            ml_png.display()
        ));
        images.push(frame);
        // The MNI head at a matched sample count (resampled on BCC/FCC).
        let head = scene::from_cartesian(&mni, &lat, Conversion::Resample).map_err(|e| e.to_string())?;
        let opts = RenderOptions {
            width: size,
            height: size,
            iso: MNI_ISO,
            step: 0.5,
            azimuth: 200.0,
            elevation: 15.0,
            frames: 1,
            ..RenderOptions::default()
        };
        let frame = render::render(&gpu, &d, &head, Layout::Embedded, &opts).map_err(|e| e.to_string())?;
        let mni_png = out.join(format!("mni_{name}.png"));
        render::write_png(&mni_png, frame.width, frame.height, &frame.rgba).map_err(|e| e.to_string())?;
        steps.println(&format!(
            "[demo] {name}: MNI head {} samples, {:.1} ms/frame -> {}",
            head.samples(),
            frame.ms_per_frame,
            mni_png.display()
        ));
        rows.push(Row {
            filter: name.to_string(),
            lattice: lat.name.clone(),
            ml_samples: ml.samples(),
            rms,
            max_err,
            ml_ms: images.last().map(|f| f.ms_per_frame).unwrap_or(0.0),
            mni_samples: head.samples(),
            mni_ms: frame.ms_per_frame,
        });
        images.push(frame);
    }
    steps.finish();
    // Contact sheet: one column per filter, Marschner-Lobb above the head.
    let sheet = contact_sheet(&images, FILTERS.len(), size);
    let sheet_png = out.join("contact_sheet.png");
    render::write_png(&sheet_png, size * FILTERS.len() as u32, size * 2, &sheet).map_err(|e| e.to_string())?;
    outln!("\n| filter | lattice | ML samples | RMS error (ML, 1e5 points) | max error | ms/frame ML {size}^2 | MNI samples | ms/frame MNI {size}^2 |");
    outln!("|---|---|---|---|---|---|---|---|");
    for r in &rows {
        outln!(
            "| {} | {} | {} | {:.5} | {:.4} | {:.1} | {} | {:.1} |",
            r.filter,
            r.lattice,
            r.ml_samples,
            r.rms,
            r.max_err,
            r.ml_ms,
            r.mni_samples,
            r.mni_ms
        );
    }
    outln!(
        "\nImages: {} (ml_*.png, mni_*.png, contact_sheet.png) on {}; total {:.1} s",
        out.display(),
        gpu.describe(),
        started.elapsed().as_secs_f64()
    );
    Ok(())
}

/// RMS and max error of the spline (GPU eval) against the analytic
/// Marschner-Lobb function at random points of the valid box.
fn ml_error(gpu: &Gpu, d: &Derivation, ml: &LatticeVolume, points: usize) -> Result<(f64, f64), String> {
    let (lo, hi) = valid_box(d, ml);
    let mut rng = Rng(2024);
    let pts: Vec<[f32; 4]> = (0..points)
        .map(|_| {
            let mut p = [0f32; 4];
            for i in 0..3 {
                p[i] = lo[i] + (rng.next_f64() as f32) * (hi[i] - lo[i]);
            }
            p
        })
        .collect();
    let dv = DeviceVolume::new(gpu, ml, Layout::Embedded).map_err(|e| e.to_string())?;
    let (values, _) = gpu_eval(gpu, d, &dv, Variant::Fast, &pts).map_err(|e| e.to_string())?;
    let mut sum = 0.0;
    let mut max: f64 = 0.0;
    for (p, v) in pts.iter().zip(&values) {
        let x = ml_position(ml.dims, [p[0] as f64, p[1] as f64, p[2] as f64]);
        let e = *v as f64 - marschner_lobb(x);
        sum += e * e;
        max = max.max(e.abs());
    }
    Ok(((sum / points as f64).sqrt(), max))
}

fn contact_sheet(frames: &[render::Frame], columns: usize, size: u32) -> Vec<u8> {
    let (w, h) = (size as usize * columns, size as usize * 2);
    let mut out = vec![0u8; w * h * 4];
    for (i, f) in frames.iter().enumerate() {
        let (col, row) = (i / 2, i % 2);
        for y in 0..f.height as usize {
            for x in 0..f.width as usize {
                let src = (y * f.width as usize + x) * 4;
                let dst = ((row * size as usize + y) * w + col * size as usize + x) * 4;
                out[dst..dst + 4].copy_from_slice(&f.rgba[src..src + 4]);
            }
        }
    }
    out
}
