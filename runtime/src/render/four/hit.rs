//! The exact-hit mode of 4D isosurfaces: the 3D exact walk
//! ([`crate::render::iso::hit`]) on the hyperplane of the frame's time, its
//! planes the traces of the 4D knot planes there ([`TimeHitPlan`]); the WGSL
//! (`templates/four_hit.wgsl.j2`) and the exact evaluator's frame.

use super::{cpu_frame, shade, FourIsoOptions};
use crate::render::iso::template::{coefficient_exprs, lit};
use crate::render::iso::{hit_exact, TimeHitPlan, HIT_DEPTH, HIT_ITERATIONS, HIT_MERGE, HIT_TOLERANCE};
use crate::volume::LatticeVolume4;
use boxforge::derive::Derivation;
use glam::DVec3;

/// The exact walk and its entry point `four_exact_main`, appended to the
/// 4D renderer's shader (it uses `four_p`, `four_ray`, `four_shade`).
pub(super) fn exact_shader(name: &str, plan: &TimeHitPlan) -> String {
    let families: Vec<minijinja::Value> = plan
        .plan
        .families
        .iter()
        .zip(&plan.time_normals)
        .map(|((n, off, g), nt)| {
            minijinja::context! {
                n => format!("{}, {}, {}", lit(n[0]), lit(n[1]), lit(n[2])),
                nt => lit(*nt),
                off => lit(*off),
                g => lit(*g),
            }
        })
        .collect();
    let p = &plan.plan;
    let count = p.samples.len();
    let mut names = Vec::new();
    for (k, &(_, grad)) in p.samples.iter().enumerate() {
        names.push(format!("vals[{k}]"));
        if grad {
            names.push(format!("ders[{k}]"));
        }
    }
    let ctx = minijinja::context! {
        name => "four_hit",
        filter => name,
        families => families,
        count => count,
        u_list => p.samples.iter().map(|&(u, _)| lit(u)).collect::<Vec<_>>().join(", "),
        shared => p.shared_ends,
        coeffs => coefficient_exprs(&p.to_bernstein, &names),
        hit => minijinja::context! {
            degree => p.degree,
            depth => HIT_DEPTH,
            iterations => HIT_ITERATIONS,
            merge => lit(HIT_MERGE),
            tolerance => lit(HIT_TOLERANCE),
        },
    };
    crate::render::templates::render("four_hit", ctx)
}

/// The exact-hit frame from the exact evaluator (f64): the same walk
/// ([`hit_exact`]) on the plan at time `t`, the reference of every device
/// frame in this mode.
pub fn cpu_reference_exact(d: &Derivation, vol: &LatticeVolume4, t: f64, o: &FourIsoOptions) -> Vec<u8> {
    let plan = TimeHitPlan::new(d).expect("a 4D filter").at(t);
    let data = |j: &[i64]| vol.get(j) as f64;
    let _ = d.f64_tables();
    let f = |x: DVec3| d.eval_f64(&[x.x, x.y, x.z, t], &data);
    let iso = o.iso as f64;
    cpu_frame(d, vol, o, |org, fwd, start, tmax| {
        if tmax <= start {
            return [0, 0, 0, 255];
        }
        let (origin, dir) = (DVec3::from_array(org), DVec3::from_array(fwd));
        match hit_exact(&f, &plan, origin, dir, start, tmax, iso) {
            Some(th) => shade(&f(origin + th * dir).1, fwd),
            None => [0, 0, 0, 255],
        }
    })
}
