//! The CPU reference of the DVR image: the same model in f64 with the
//! exact evaluator, and the RMS difference the tests compare images by.

use super::{dvr_params, DvrOptions, DvrParams, BACKGROUND};
use crate::render::dvr::transfer::{Preint, Tf1d, TransferFunction};
use crate::volume::LatticeVolume;
use boxforge::derive::Derivation;
use glam::{DVec3, Vec3};

/// The xyz of a uniform vector, widened to f64 (exactly).
fn d3(a: [f32; 4]) -> DVec3 {
    Vec3::from_slice(&a[..3]).as_dvec3()
}

/// The same renderer on the CPU in f64 with the exact evaluator
/// (`Derivation::eval_f64`), the same tables and no skipping (so matching
/// it also tests the skipping). Rows run on every core.
pub fn cpu_render(d: &Derivation, vol: &LatticeVolume, tf: &TransferFunction, o: &DvrOptions) -> Vec<u8> {
    let table = tf.table();
    let pi = o.preintegrate.then(|| table.preintegrate(o.step as f64));
    let p = dvr_params(d, vol, &table, pi.as_ref().map_or(2, |p| p.size), o);
    let data = |j: &[i64]| vol.get(j) as f64;
    let f = |x: DVec3| d.eval_f64(&x.to_array(), &data);
    // The curvature transfer function: (colour, opacity factor) from the Hessian.
    let curvature = |x: DVec3, r: f64| {
        let (_, g, h) = d.eval_f64_hessian(&x.to_array(), &data);
        crate::render::iso::curvature::curvature_tf(DVec3::from_slice(&g), glam::DMat3::from_cols_slice(&h), r)
    };
    let (w, h) = (o.width as usize, o.height as usize);
    let rows: Vec<usize> = (0..h).collect();
    let threads = std::thread::available_parallelism().map(|n| n.get()).unwrap_or(1);
    let mut out = vec![0u8; w * h * 4];
    std::thread::scope(|s| {
        let handles: Vec<_> = rows
            .chunks(h.div_ceil(threads).max(1))
            .map(|rows| {
                let (f, table, pi, p, curvature) = (&f, &table, pi.as_ref(), &p, &curvature);
                s.spawn(move || {
                    let mut part = Vec::new();
                    for &y in rows {
                        for x in 0..w {
                            let sx = (x as f64 + 0.5) / w as f64 * 2.0 - 1.0;
                            let sy = 1.0 - (y as f64 + 0.5) / h as f64 * 2.0;
                            let (eye, fw, rt, up) =
                                (d3(p.camera.eye), d3(p.camera.forward), d3(p.camera.right), d3(p.camera.up));
                            let (origin, dir) = if o.perspective {
                                let dv = fw + sx * rt + sy * up;
                                (eye, dv / dv.length())
                            } else {
                                (eye + sx * rt + sy * up, fw)
                            };
                            part.push((y, x, cast_ray(f, curvature, table, pi, origin, dir, p, o)));
                        }
                    }
                    part
                })
            })
            .collect();
        for hnd in handles {
            for (y, x, c) in hnd.join().expect("cpu dvr") {
                let i = (y * w + x) * 4;
                out[i..i + 4].copy_from_slice(&c);
            }
        }
    });
    out
}

#[allow(clippy::too_many_arguments)] // the shader's inputs, one by one
fn cast_ray(
    f: &dyn Fn(DVec3) -> (f64, Vec<f64>),
    curvature: &dyn Fn(DVec3, f64) -> (DVec3, f64),
    table: &Tf1d,
    pi: Option<&Preint>,
    origin: DVec3,
    dir: DVec3,
    p: &DvrParams,
    o: &DvrOptions,
) -> [u8; 4] {
    let at = |t: f64| origin + t * dir;
    let (mut t0, mut t1) = (0f64, f64::INFINITY);
    for i in 0..3 {
        let a = (p.camera.box_lo[i] as f64 - origin[i]) / dir[i];
        let b = (p.camera.box_hi[i] as f64 - origin[i]) / dir[i];
        t0 = t0.max(a.min(b));
        t1 = t1.min(a.max(b));
    }
    let up = d3(p.camera.up);
    let l = {
        let v = -dir + 0.35 * up / up.length().max(1e-20);
        v / v.length()
    };
    let hv = {
        let v = l - dir;
        v / v.length()
    };
    let (ka, kd, ks, g0) = (p.light[0] as f64, p.light[1] as f64, p.light[2] as f64, p.light[3] as f64);
    let step = o.step as f64;
    let mut acc = DVec3::ZERO;
    let mut alpha = 0.0f64;
    if t0 < t1 {
        let nseg = ((t1 - t0) / step).floor() as i64;
        let (mut sf, g) = f(at(t0));
        let mut gf = DVec3::from_slice(&g);
        for k in 0..nseg {
            if alpha >= o.termination as f64 {
                break;
            }
            let (sb, g) = f(at(t0 + (k + 1) as f64 * step));
            let gb = DVec3::from_slice(&g);
            let (mut seg, g) = match pi {
                Some(pi) => (pi.at(sf, sb), 0.5 * (gf + gb)),
                None => {
                    let s = table.at(sb);
                    let a = 1.0 - (-s[3] * step).exp();
                    ([s[0] * a, s[1] * a, s[2] * a, a], gb)
                }
            };
            if let Some(r) = o.curvature {
                let (c, m) = curvature(at(t0 + (k + 1) as f64 * step), r as f64);
                let a = seg[3] * m;
                seg = [c.x * a, c.y * a, c.z * a, a];
            }
            if seg[3] > 0.0 {
                let g2 = g.length_squared();
                let wgt = g2 / (g2 + g0 * g0);
                let n = g / g2.sqrt().max(1e-20);
                let diffuse = n.dot(l).abs();
                let specular = n.dot(hv).abs().powi(20);
                let c = DVec3::new(seg[0], seg[1], seg[2]);
                let lit = c * (ka + kd * diffuse) + DVec3::splat(seg[3] * ks * specular);
                acc += (1.0 - alpha) * (c + (lit - c) * wgt);
                alpha += (1.0 - alpha) * seg[3];
            }
            (sf, gf) = (sb, gb);
        }
    }
    let color = acc + (1.0 - alpha) * DVec3::from_array(BACKGROUND);
    let q = |v: f64| (v.clamp(0.0, 1.0) * 255.0 + 0.5) as u8;
    [q(color[0]), q(color[1]), q(color[2]), 255]
}

/// RMS difference of the RGB channels of two RGBA8 images, in 1/255 units.
pub fn rms(a: &[u8], b: &[u8]) -> f64 {
    assert_eq!(a.len(), b.len(), "images of the same size");
    let (mut sum, mut n) = (0.0, 0usize);
    for (pa, pb) in a.chunks(4).zip(b.chunks(4)) {
        for c in 0..3 {
            let dlt = pa[c] as f64 - pb[c] as f64;
            sum += dlt * dlt;
            n += 1;
        }
    }
    (sum / n.max(1) as f64).sqrt()
}
