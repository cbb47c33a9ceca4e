//! Accuracy against Marschner-Lobb, convergence on a smooth signal, and
//! plain evaluation rates.

use super::job::{program, timed_rounds, Job};
use super::options::derive_filter;
use super::{BenchError, BenchOptions, ConvergenceRow, QualityRow};
use crate::gpu::Gpu;
use crate::prefilter::prefilter_cpu;
use crate::render::iso::valid_box;
use crate::verify::Rng;
use crate::volume::{marschner_lobb, marschner_lobb_grad, ml_position, DeviceVolume, LatticeVolume};
use boxforge::derive::Derivation;
use boxforge::emit::{emit, EmitOptions, Layout, Variant};

fn angle_deg(a: [f64; 3], b: [f64; 3]) -> Option<f64> {
    let na = (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt();
    let nb = (b[0] * b[0] + b[1] * b[1] + b[2] * b[2]).sqrt();
    if na < 1e-9 || nb < 1e-9 {
        return None;
    }
    let c = ((a[0] * b[0] + a[1] * b[1] + a[2] * b[2]) / (na * nb)).clamp(-1.0, 1.0);
    Some(c.acos().to_degrees())
}

pub(super) fn points_in(d: &Derivation, vol: &LatticeVolume, n: usize, seed: u64) -> Vec<[f32; 4]> {
    let (lo, hi) = valid_box(d, vol);
    let mut rng = Rng(seed);
    (0..n)
        .map(|_| {
            let mut p = [0f32; 4];
            for i in 0..3 {
                p[i] = lo[i] + rng.next_f64() as f32 * (hi[i] - lo[i]);
            }
            p
        })
        .collect()
}

/// Mean angle error of gradients (in lattice coordinates) against the
/// analytic ML gradient (chain rule through the lattice-to-[-1,1] map).
pub(super) fn ml_angle(vol: &LatticeVolume, pts: &[[f32; 4]], grads: &[[f32; 4]]) -> f64 {
    let (mut sum, mut n) = (0.0, 0);
    for (p, g) in pts.iter().zip(grads) {
        let x = ml_position(vol.dims, [p[0] as f64, p[1] as f64, p[2] as f64]);
        let ga = marschner_lobb_grad(x);
        // d/dj = d/dx * 2/(n-1): positive per-axis scale, so rescale.
        let s: Vec<f64> = (0..3).map(|i| 2.0 / (vol.dims[i] as f64 - 1.0)).collect();
        let ga = [ga[0] * s[0], ga[1] * s[1], ga[2] * s[2]];
        if let Some(a) = angle_deg([g[1] as f64, g[2] as f64, g[3] as f64], ga) {
            sum += a;
            n += 1;
        }
    }
    sum / n.max(1) as f64
}

pub(super) fn quality(
    gpu: &Gpu,
    o: &BenchOptions,
    progress: &dyn Fn(&str),
) -> Result<(Vec<QualityRow>, Vec<ConvergenceRow>), BenchError> {
    let mut q = Vec::new();
    let mut conv = Vec::new();
    let cc_budget = 41f64.powi(3);
    let npts = o.points.min(100_000);
    for name in &o.filters {
        let d = derive_filter(name)?;
        if d.facts.dim != 3 {
            continue;
        }
        let det = d.filter.lattice.det();
        let budgets: Vec<(String, f64)> = if det == 1 {
            vec![("41^3".into(), cc_budget)]
        } else {
            vec![("same as 41^3".into(), cc_budget), ("29.3% fewer".into(), cc_budget * 0.707)]
        };
        for (label, budget) in budgets {
            let edge = crate::scene::matched_edge(&d.filter.lattice, budget);
            let ml = LatticeVolume::marschner_lobb(&d.filter.lattice, [edge, edge, edge])?;
            for pre in [false, true] {
                progress(&format!("{name} quality {label} prefilter={pre}"));
                let v = if pre { prefilter_cpu(&d, &ml) } else { ml.clone() };
                let pts = points_in(&d, &v, npts, 9);
                let dv = DeviceVolume::new(gpu, &v, Layout::Embedded)?;
                let (_, g) = crate::verify::gpu_eval(gpu, &d, &dv, Variant::Fast, &pts)?;
                let (mut sum, mut max) = (0.0, 0f64);
                for (p, gv) in pts.iter().zip(&g) {
                    let x = ml_position(v.dims, [p[0] as f64, p[1] as f64, p[2] as f64]);
                    let err = gv[0] as f64 - marschner_lobb(x);
                    sum += err * err;
                    max = max.max(err.abs());
                }
                q.push(QualityRow {
                    filter: name.clone(),
                    lattice: d.filter.lattice.name.clone(),
                    samples: v.samples(),
                    budget: label.clone(),
                    prefiltered: pre,
                    rms_error: (sum / pts.len() as f64).sqrt(),
                    max_error: max,
                    gradient_angle_deg: ml_angle(&v, &pts, &g),
                });
            }
        }
        progress(&format!("{name} convergence"));
        let edges: Vec<usize> = vec![16, 24, 32];
        let errs = smooth_convergence(gpu, &d, &edges)?;
        let hs: Vec<f64> = edges.iter().map(|&n| 1.0 / n as f64).collect();
        let k = errs.len() - 1;
        let order = (errs[k - 1] / errs[k]).ln() / (hs[k - 1] / hs[k]).ln();
        conv.push(ConvergenceRow {
            filter: name.clone(),
            approximation_order: d.facts.approximation_order,
            edges,
            rms_errors: errs,
            measured_order: order,
        });
    }
    Ok((q, conv))
}

/// evals/s of the default module's `<f>_eval` on `dv` at `points`, one rate
/// per round (`rounds` timed dispatches after a warm-up).
///
/// # Errors
///
/// Emission or device errors.
pub fn eval_rates(
    gpu: &Gpu,
    d: &Derivation,
    dv: &DeviceVolume,
    points: &[[f32; 4]],
    rounds: usize,
) -> Result<Vec<f64>, BenchError> {
    let name = &d.filter.name;
    let m = emit(d, &EmitOptions { layout: dv.layout, kernels: false, ..Default::default() })?;
    let src = program(&m.source, "", &format!("vec4<f32>({name}_eval(p), 0.0, 0.0, 0.0)"));
    let job = Job::new(gpu, &src, &m.file_name, dv, points)?;
    let rates = timed_rounds(gpu, &[&job], rounds.max(1))?;
    Ok(rates.into_iter().next().unwrap_or_default())
}

/// RMS error of the prefiltered spline against the smooth signal
/// f = cos(1.5x) cos(y) cos(0.5z) on [-1,1]^3 sampled with n cells per unit
/// length 2, for each n in `edges` (4000 points in the central half): the
/// convergence curve whose slope is the measured approximation order.
///
/// # Errors
///
/// Device errors.
pub fn smooth_convergence(gpu: &Gpu, d: &Derivation, edges: &[usize]) -> Result<Vec<f64>, BenchError> {
    let smooth = |x: [f64; 3]| (1.5 * x[0]).cos() * x[1].cos() * (0.5 * x[2]).cos();
    let mut errs = Vec::new();
    for &n in edges {
        let r = crate::volume::support_radius(d);
        let dims = [n + 2 * r + 2; 3];
        // Map the inner n cells onto [-1,1]: x = -1 + 2 (j - r - 1) / n.
        let off = (r + 1) as f64;
        let to_x = |j: [f64; 3]| [0, 1, 2].map(|i| -1.0 + 2.0 * (j[i] - off) / n as f64);
        let mut v =
            LatticeVolume { lattice: d.filter.lattice.clone(), dims, data: vec![0.0; dims[0] * dims[1] * dims[2]] };
        for z in 0..dims[2] {
            for y in 0..dims[1] {
                for x in 0..dims[0] {
                    if v.is_lattice(&[x as i64, y as i64, z as i64]) {
                        v.data[x + dims[0] * (y + dims[1] * z)] = smooth(to_x([x as f64, y as f64, z as f64])) as f32;
                    }
                }
            }
        }
        let v = prefilter_cpu(d, &v);
        let mut rng = Rng(3);
        let pts: Vec<[f32; 4]> = (0..4000)
            .map(|_| {
                let mut p = [0f32; 4];
                for pi in p.iter_mut().take(3) {
                    *pi = (off + 0.25 * n as f64 + rng.next_f64() * 0.5 * n as f64) as f32;
                }
                p
            })
            .collect();
        let dv = DeviceVolume::new(gpu, &v, Layout::Embedded)?;
        let (vals, _) = crate::verify::gpu_eval(gpu, d, &dv, Variant::Fast, &pts)?;
        let rms = (pts
            .iter()
            .zip(&vals)
            .map(|(p, val)| {
                let e = *val as f64 - smooth(to_x([p[0] as f64, p[1] as f64, p[2] as f64]));
                e * e
            })
            .sum::<f64>()
            / pts.len() as f64)
            .sqrt();
        errs.push(rms);
    }
    Ok(errs)
}
