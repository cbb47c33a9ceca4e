//! The ray-casting template (`templates/raycast.wgsl.j2`) filled for a
//! filter: the fixed-step walk, or the exact walk with the hit plan's
//! sampling and Bernstein conversion written out as WGSL.

use super::hit::*;

/// f32 literal for WGSL.
pub(crate) fn lit(x: f64) -> String {
    format!("{:?}", x as f32)
}

/// Coefficient expressions c_j = sum_k w_jk names_k.
pub(crate) fn coefficient_exprs(m: &[Vec<f64>], names: &[String]) -> Vec<String> {
    m.iter()
        .map(|row| {
            let terms: Vec<String> = row
                .iter()
                .zip(names)
                .filter(|(w, _)| w.abs() > 1e-12)
                .map(|(&w, v)| if (w - 1.0).abs() < 1e-12 { v.clone() } else { format!("{} * {v}", lit(w)) })
                .collect();
            if terms.is_empty() {
                "0.0".to_string()
            } else {
                terms.join(" + ")
            }
        })
        .collect()
}

/// The minijinja context of the exact walk for this plan: the sampling code
/// of one segment [t, te] (length len; `pv`, `pg`, `ps` the value, d/dt and
/// d²/dt² carried from the previous segment's end when `have`), assigning
/// the Bernstein coefficients c_j, and the carry to the next segment.
fn hit_context(plan: &HitPlan, name: &str) -> minijinja::Value {
    let families: Vec<minijinja::Value> = plan
        .families
        .iter()
        .map(|(n, off, g)| {
            minijinja::context! {
                n => format!("{}, {}, {}", lit(n[0]), lit(n[1]), lit(n[2])),
                off => lit(*off),
                g => lit(*g),
            }
        })
        .collect();
    let n = plan.degree;
    let last = plan.samples.len() - 1;
    let pos = |x: f64| format!("o + (t + len * {}) * dir", lit(x));
    let sample = |code: &mut String, v: &str, dv: &str, p: &str, grad: bool, indent: &str| {
        if grad {
            *code += &format!(
                "{indent}let g{v} = {name}_eval_grad({p});\n{indent}let {v} = g{v}.x - iso;\n{indent}let {dv} = len * dot(g{v}.yzw, dir);\n"
            );
        } else {
            *code += &format!("{indent}let {v} = {name}_eval({p}) - iso;\n");
        }
    };
    let mut code = String::new();
    let mut names = Vec::new();
    let (start_grad, end_grad) = (plan.samples[0].1, plan.samples[last].1);
    if plan.shared_ends {
        let fresh = if start_grad {
            format!("let g = {name}_eval_grad(o + t * dir);\n            pv = g.x - iso;\n            pg = dot(g.yzw, dir);")
        } else {
            format!("pv = {name}_eval(o + t * dir) - iso;")
        };
        code += &format!(
            "        if (!have) {{\n            {fresh}\n            ps = 0.0;\n        }}\n        let v0 = pv;\n"
        );
        if start_grad {
            code += "        let d0 = len * pg;\n";
        }
        sample(&mut code, "ve", "de", "o + te * dir", end_grad, "        ");
    }
    let carry = !plan.carried_to_bernstein.is_empty();
    code += &(0..=n).map(|j| format!("        var c{j} = 0.0;\n")).collect::<String>();
    let mut fresh_code = String::new();
    for (i, &(x, grad)) in plan.samples.iter().enumerate() {
        if plan.shared_ends && i == 0 {
            names.push("v0".to_string());
            if grad {
                names.push("d0".to_string());
            }
        } else if plan.shared_ends && i == last {
            names.push("ve".to_string());
            if grad {
                names.push("de".to_string());
            }
        } else {
            let (v, dv) = (format!("v{i}"), format!("d{i}"));
            sample(&mut fresh_code, &v, &dv, &pos(x), grad, "            ");
            names.push(v);
            if grad {
                names.push(dv);
            }
        }
    }
    for (j, e) in coefficient_exprs(&plan.to_bernstein, &names).iter().enumerate() {
        fresh_code += &format!("            c{j} = {e};\n");
    }
    if carry {
        let mut carried_code = String::from("            let s0 = len * len * ps;\n");
        let mut cnames: Vec<String> = ["v0", "d0", "s0"].map(String::from).to_vec();
        for (k, &x) in plan.carried_samples.iter().enumerate() {
            let (v, dv) = (format!("vc{k}"), format!("dc{k}"));
            sample(&mut carried_code, &v, &dv, &pos(x), true, "            ");
            cnames.push(v);
            cnames.push(dv);
        }
        cnames.push("ve".into());
        cnames.push("de".into());
        for (j, e) in coefficient_exprs(&plan.carried_to_bernstein, &cnames).iter().enumerate() {
            carried_code += &format!("            c{j} = {e};\n");
        }
        code += &format!(
            "        if (have && len * len * acc <= {}) {{\n{carried_code}        }} else {{\n{fresh_code}            acc = 0.0;\n        }}\n",
            lit(HIT_CARRY_BOUND)
        );
    } else {
        code += &format!("        {{\n{fresh_code}        }}\n");
    }
    let mut carry_code = String::new();
    if plan.shared_ends {
        carry_code = "pv = ve;".into();
        if end_grad {
            carry_code += " pg = dot(gve.yzw, dir);";
        }
        if carry {
            carry_code += &format!(
                " ps = {}.0 * (c{n} - 2.0 * c{} + c{}) / (len * len); acc += 1.0 / (len * len);",
                n * (n - 1),
                n - 1,
                n - 2
            );
        }
    }
    if plan.ray_bernstein.is_some() {
        code = format!(
            "        let cb = {name}_ray_bernstein(o + t * dir, o + te * dir, iso);\n{}",
            (0..=n).map(|j| format!("        let c{j} = cb[{j}];\n")).collect::<String>()
        );
        carry_code = String::new();
    }
    minijinja::context! {
        helper => plan.ray_bernstein.clone().unwrap_or_default(),
        families => families,
        degree => n,
        samples => code,
        carry => carry_code,
        grid_offset => format!("{}, {}, {}", lit(plan.grid_offset[0]), lit(plan.grid_offset[1]), lit(plan.grid_offset[2])),
        merge => lit(HIT_MERGE),
        depth => HIT_DEPTH,
        iterations => HIT_ITERATIONS,
        tolerance => lit(HIT_TOLERANCE),
    }
}

/// The ray caster for this filter: the fixed-step walk, or with `exact`
/// the exact walk over a fine bounds grid of `fine` = (edge, blocks per axis);
/// with `host_depth` the host-depth input of the native per-frame renderer
/// (bindings 6 and 7; without it the text is the one the web viewer and
/// reports have always had).
pub(crate) fn template(
    name: &str,
    exact: Option<(&HitPlan, i32, [i32; 3])>,
    host_depth: bool,
    curvature: bool,
) -> String {
    let ctx = match exact {
        Some((plan, edge, blocks)) => minijinja::context! {
            name => name,
            exact => true,
            fine_edge => edge,
            fine_blocks_x => blocks[0],
            fine_blocks_y => blocks[1],
            fine_blocks_z => blocks[2],
            hit => hit_context(plan, name),
            host_depth => host_depth,
            curvature => curvature,
        },
        None => minijinja::context! { name => name, exact => false, host_depth => host_depth, curvature => curvature },
    };
    crate::render::templates::render("raycast", ctx)
}

/// The fixed-step ray caster paged out of core (bindings 8 and 9: the
/// per-pixel resume state and the brick request bitset), appended to a
/// module emitted for the bricked layout.
pub(crate) fn paged_template(name: &str) -> String {
    let ctx = minijinja::context! { name => name, exact => false, host_depth => false, paged => true };
    crate::render::templates::render("raycast", ctx)
}
