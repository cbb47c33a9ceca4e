//! The CPU reference ray caster (the exact evaluator in f64): what the tests
//! compare the device's images and hit depths with.

use super::hit::*;
use super::{d3, ray_params, HitMode, RayParams, RenderOptions};
use crate::volume::LatticeVolume;
use boxforge::derive::Derivation;
use glam::DVec3;

/// The same ray caster on the CPU with the exact evaluator in f64 (no
/// skipping: it must give the same image, which tests the skipping too).
pub fn cpu_render(d: &Derivation, vol: &LatticeVolume, o: &RenderOptions) -> Vec<u8> {
    cpu_render_with_depth(d, vol, o).0
}

/// [`cpu_render`], and the ray parameter t of every pixel's hit (-1 for a miss).
pub fn cpu_render_with_depth(d: &Derivation, vol: &LatticeVolume, o: &RenderOptions) -> (Vec<u8>, Vec<f32>) {
    let p = ray_params(d, vol, o);
    let plan = HitPlan::new(d);
    let data = |j: &[i64]| vol.get(j) as f64;
    let f = |x: DVec3| d.eval_f64(&x.to_array(), &data);
    // Curvature shading: gradient and Hessian at the hit.
    let second = |x: DVec3| {
        let (_, g, h) = d.eval_f64_hessian(&x.to_array(), &data);
        (DVec3::from_slice(&g), glam::DMat3::from_cols_slice(&h))
    };
    let (w, h) = (o.width as usize, o.height as usize);
    let rows: Vec<usize> = (0..h).collect();
    let threads = std::thread::available_parallelism().map(|n| n.get()).unwrap_or(1);
    let chunks: Vec<Vec<usize>> = rows.chunks(h.div_ceil(threads)).map(|c| c.to_vec()).collect();
    let mut out = vec![0u8; w * h * 4];
    let mut depth = vec![-1f32; w * h];
    std::thread::scope(|s| {
        let handles: Vec<_> = chunks
            .iter()
            .map(|rows| {
                let (f, plan, second) = (&f, &plan, &second);
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
                            let (c, t) = cast_ray(f, second, plan, origin, dir, &p, o);
                            part.push((y, x, c, t));
                        }
                    }
                    part
                })
            })
            .collect();
        for hnd in handles {
            for (y, x, c, t) in hnd.join().expect("cpu ray cast") {
                let i = (y * w + x) * 4;
                out[i..i + 4].copy_from_slice(&c);
                depth[y * w + x] = t.map_or(-1.0, |t| t as f32);
            }
        }
    });
    (out, depth)
}

/// The first hit by fixed steps and bisection (as the shader's step mode).
fn hit_step(
    f: &dyn Fn(DVec3) -> (f64, Vec<f64>),
    origin: DVec3,
    dir: DVec3,
    t0: f64,
    t1: f64,
    o: &RenderOptions,
) -> Option<f64> {
    let at = |t: f64| origin + t * dir;
    let iso = o.iso as f64;
    let step = o.step as f64;
    let mut t = t0;
    let mut prev = f(at(t)).0 - iso;
    let mut hit = None;
    while t < t1 {
        let tn = (t + step).min(t1);
        let v = f(at(tn)).0 - iso;
        if (prev < 0.0) != (v < 0.0) {
            hit = Some((t, tn));
            break;
        }
        prev = v;
        t = tn;
    }
    let (mut a, mut b) = hit?;
    let sa = f(at(a)).0 - iso < 0.0;
    while b - a >= 1e-4 {
        let m = 0.5 * (a + b);
        if (f(at(m)).0 - iso < 0.0) == sa {
            a = m;
        } else {
            b = m;
        }
    }
    Some(0.5 * (a + b))
}

/// The exact first hit: the ray from the box entry is cut at every plane
/// of the plan, each segment sampled as the plan says, its Bernstein
/// coefficients tested for one sign and otherwise searched with
/// [`first_root`] (the shader's exact walk in f64, without skipping). `f`
/// gives the value and gradient.
pub fn hit_exact(
    f: &dyn Fn(DVec3) -> (f64, Vec<f64>),
    plan: &HitPlan,
    origin: DVec3,
    dir: DVec3,
    t0: f64,
    t1: f64,
    iso: f64,
) -> Option<f64> {
    let o = origin + t0 * dir;
    let tend = t1 - t0;
    let fam: Vec<(f64, f64, f64)> = plan
        .families
        .iter()
        .map(|(n, off, g)| (DVec3::from_array(*n).dot(o) - off, DVec3::from_array(*n).dot(dir), *g))
        .collect();
    let steps: Vec<f64> =
        fam.iter().map(|&(_, b, g)| if b.abs() > 1e-9 { g / b.abs() } else { f64::INFINITY }).collect();
    let mut next: Vec<f64> = fam.iter().map(|&(a, b, g)| next_crossing(a, b, g, 0.0)).collect();
    let last = plan.samples.len() - 1;
    // Value and d/dt along the ray.
    let sample = |t: f64| {
        let (v, g) = f(o + t * dir);
        (v - iso, DVec3::from_slice(&g).dot(dir))
    };
    let carry = !plan.carried_to_bernstein.is_empty();
    let mut t = 0.0;
    // Value, d/dt and d²/dt² at the previous segment's end, and the sum of
    // 1 / len² over the carry chain (see HIT_CARRY_BOUND).
    let mut prev: Option<(f64, f64, f64, f64)> = None;
    let mut cond = Vec::with_capacity(plan.degree + 1);
    while t < tend {
        let te = next.iter().fold(tend, |m, &x| m.min(x));
        for (x, s) in next.iter_mut().zip(&steps) {
            if *x <= te + HIT_MERGE {
                *x += s;
            }
        }
        if te < tend && te - t < HIT_MERGE {
            continue;
        }
        let len = te - t;
        cond.clear();
        let start = match prev {
            Some((v, dt, _, _)) if plan.shared_ends => (v, dt),
            _ => sample(t),
        };
        let end = if plan.shared_ends { sample(te) } else { (0.0, 0.0) };
        let carried = match prev {
            Some((_, _, _, acc)) => carry && len * len * acc <= HIT_CARRY_BOUND,
            None => false,
        };
        let c = match prev {
            Some((_, _, s, _)) if carried => {
                cond.extend([start.0, len * start.1, len * len * s]);
                for &u in &plan.carried_samples {
                    let (v, dt) = sample(t + len * u);
                    cond.extend([v, len * dt]);
                }
                cond.extend([end.0, len * end.1]);
                plan.coefficients_with(&plan.carried_to_bernstein, &cond)
            }
            _ => {
                for (i, &(u, grad)) in plan.samples.iter().enumerate() {
                    let (v, dt) = match i {
                        0 if plan.shared_ends => start,
                        _ if plan.shared_ends && i == last => end,
                        _ => sample(t + len * u),
                    };
                    cond.push(v);
                    if grad {
                        cond.push(len * dt);
                    }
                }
                plan.coefficients(&cond)
            }
        };
        let lo = c.iter().fold(f64::INFINITY, |m, &x| m.min(x));
        let hi = c.iter().fold(f64::NEG_INFINITY, |m, &x| m.max(x));
        if lo < 0.0 && hi >= 0.0 {
            if let Some(u) = first_root(&c, HIT_TOLERANCE / len) {
                return Some(t0 + t + u * len);
            }
        }
        let s = if carry { end_second_derivative(&c, len) } else { 0.0 };
        let acc = match prev {
            Some((_, _, _, acc)) if carried => acc,
            _ => 0.0,
        } + 1.0 / (len * len);
        prev = Some((end.0, end.1, s, acc));
        t = te;
    }
    None
}

fn cast_ray(
    f: &dyn Fn(DVec3) -> (f64, Vec<f64>),
    second: &dyn Fn(DVec3) -> (DVec3, glam::DMat3),
    plan: &HitPlan,
    origin: DVec3,
    dir: DVec3,
    p: &RayParams,
    o: &RenderOptions,
) -> ([u8; 4], Option<f64>) {
    let at = |t: f64| origin + t * dir;
    let (mut t0, mut t1) = (0f64, f64::INFINITY);
    for i in 0..3 {
        let a = (p.camera.box_lo[i] as f64 - origin[i]) / dir[i];
        let b = (p.camera.box_hi[i] as f64 - origin[i]) / dir[i];
        t0 = t0.max(a.min(b));
        t1 = t1.min(a.max(b));
    }
    let mut color = DVec3::new(0.08, 0.08, 0.1);
    let mut hit = None;
    if t0 < t1 {
        hit = match o.hit {
            HitMode::Step => hit_step(f, origin, dir, t0, t1, o),
            HitMode::Exact => hit_exact(f, plan, origin, dir, t0, t1, o.iso as f64),
        };
        if let (Some(th), true) = (hit, o.shade.mode.needs_hessian()) {
            // The Hessian is symmetric, so its row-major entries read as columns are the same matrix.
            let (g, h) = second(at(th));
            color = o.shade.color(g, h, dir, d3(p.camera.up));
        } else if let Some(th) = hit {
            // Normalised by dividing by the length (not glam's normalize,
            // which multiplies by the reciprocal) to keep the rounding.
            let g = DVec3::from_slice(&f(at(th)).1);
            let mut n = g / g.length().max(1e-20);
            if n.dot(dir) > 0.0 {
                n = -n;
            }
            let up = d3(p.camera.up);
            let ul = up.length().max(1e-20);
            let l = {
                let v = -dir + 0.35 * up / ul;
                v / v.length()
            };
            let hv = {
                let v = l - dir;
                v / v.length()
            };
            let diffuse = n.dot(l).max(0.0);
            let specular = n.dot(hv).max(0.0).powf(40.0);
            color = DVec3::new(0.85, 0.72, 0.55) * (0.15 + 0.75 * diffuse) + 0.3 * specular;
        }
    }
    let q = |v: f64| (v.clamp(0.0, 1.0) * 255.0 + 0.5) as u8;
    ([q(color[0]), q(color[1]), q(color[2]), 255], hit)
}
