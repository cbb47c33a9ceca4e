//! `boxforge demo`: the measurements of the demo page (errors against the
//! analytic Marschner-Lobb function, evaluation rate).

use boxforge::derive::Derivation;
use boxforge::emit::{Layout, Variant};
use boxforge_runtime::gpu::Gpu;
use boxforge_runtime::render::iso::valid_box;
use boxforge_runtime::verify::{gpu_eval, Rng};
use boxforge_runtime::volume::DeviceVolume;
use boxforge_runtime::volume::{marschner_lobb, ml_position, LatticeVolume};

/// RMS and max error of the spline (GPU eval) against the analytic
/// Marschner-Lobb function at random points of the valid box.
pub fn ml_error(gpu: &Gpu, d: &Derivation, ml: &LatticeVolume, points: usize) -> Result<(f64, f64), String> {
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

/// |spline - analytic| on a square grid over the middle z slice of the valid box.
pub struct Slice {
    pub width: u32,
    pub z: f32,
    pub values: Vec<f64>,
}

pub fn error_slice(gpu: &Gpu, d: &Derivation, ml: &LatticeVolume, size: u32) -> Result<Slice, String> {
    let (lo, hi) = valid_box(d, ml);
    let n = (size / 2).max(16);
    let z = 0.5 * (lo[2] + hi[2]);
    let pts: Vec<[f32; 4]> = (0..n * n)
        .map(|i| {
            let (x, y) = ((i % n) as f32 + 0.5, (i / n) as f32 + 0.5);
            [lo[0] + x / n as f32 * (hi[0] - lo[0]), hi[1] - y / n as f32 * (hi[1] - lo[1]), z, 0.0]
        })
        .collect();
    let dv = DeviceVolume::new(gpu, ml, Layout::Embedded).map_err(|e| e.to_string())?;
    let (values, _) = gpu_eval(gpu, d, &dv, Variant::Fast, &pts).map_err(|e| e.to_string())?;
    let values = pts
        .iter()
        .zip(&values)
        .map(|(p, v)| (*v as f64 - marschner_lobb(ml_position(ml.dims, [p[0] as f64, p[1] as f64, p[2] as f64]))).abs())
        .collect();
    Ok(Slice { width: n, z, values })
}

/// evals/s of `<f>_eval` at 2^18 random points of the volume: the median of
/// three timed dispatches after a warm-up (a figure for the plot; the
/// benchmark's interleaved ratios are in docs/BENCHMARKS.md).
pub fn evals_per_second(gpu: &Gpu, d: &Derivation, vol: &LatticeVolume) -> Result<f64, String> {
    let pts = boxforge_runtime::verify::random_points(d, vol, 1 << 18, 5);
    let dv = DeviceVolume::new(gpu, vol, Layout::Embedded).map_err(|e| e.to_string())?;
    let rates = boxforge_runtime::bench::eval_rates(gpu, d, &dv, &pts, 3).map_err(|e| e.to_string())?;
    let mut r = rates;
    r.sort_by(f64::total_cmp);
    Ok(r[r.len() / 2])
}
