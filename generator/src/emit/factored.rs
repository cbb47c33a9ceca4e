//! The factored form of a tensor-product filter ([`Factorisation`]): per
//! coset, one-dimensional weights per axis, then a contraction axis by axis
//! (tricubic: 3 x 4 weights, then 16 + 4 + 1 four-term sums). The gradient
//! carries derivative weights through the same contraction, the Hessian
//! second-derivative weights as well.

use super::writer::{linear_combination, lit, Body, Shapes, AXES};
use crate::derive::factor::{bernstein_01, odometer, Factorisation};
use crate::derive::Derivation;
use crate::math::exact::Q;

/// sum_e c_e t^e with the powers named in `pows` (pows[e] = t^e; pows[0] unused).
fn poly_expr(coeffs: &[Q], pows: &[String]) -> String {
    let mut out = String::new();
    for (e, c) in coeffs.iter().enumerate() {
        if c.is_zero() {
            continue;
        }
        let mag = c.abs();
        let piece = if e == 0 {
            lit(&mag)
        } else if mag.is_one() {
            pows[e].clone()
        } else {
            format!("{} * {}", lit(&mag), pows[e])
        };
        if out.is_empty() {
            out = if c.is_negative() { format!("-{piece}") } else { piece };
        } else {
            out.push_str(if c.is_negative() { " - " } else { " + " });
            out.push_str(&piece);
        }
    }
    if out.is_empty() {
        "0.0".into()
    } else {
        out
    }
}

/// Names t^0 ..= t^deg (t^0 = "1.0", t^1 = t itself, higher ones bound once).
fn powers(body: &mut Body, t: &str, deg: usize) -> Vec<String> {
    let mut pows = vec!["1.0".to_string(), t.to_string()];
    for e in 2..=deg {
        let prev = pows[e - 1].clone();
        pows.push(body.bind("tp", &format!("{prev} * {t}")));
    }
    pows
}

/// The B-spline coordinate of coset v: s = (p - v) / a + n / 2 (per axis),
/// written with as few operations as the constants allow.
fn coset_coordinate(fac: &Factorisation, sh: &Shapes, v: &[i64], p: &str) -> String {
    let s = sh.s;
    let mul: Vec<Q> = fac.axes.iter().map(|a| Q::frac(1, a.step)).collect();
    let add: Vec<Q> = (0..s).map(|i| Q::frac(fac.axes[i].order as i64, 2) - Q::frac(v[i], fac.axes[i].step)).collect();
    let vecq = |q: &[Q]| -> String {
        if q.iter().all(|x| *x == q[0]) {
            lit(&q[0])
        } else {
            sh.fvec(&q.iter().map(lit).collect::<Vec<_>>())
        }
    };
    let mut sx = p.to_string();
    if !mul.iter().all(|m| m.is_one()) {
        sx = format!("{sx} * {}", vecq(&mul));
    }
    if !add.iter().all(|a| a.is_zero()) {
        sx = format!("{sx} + {}", vecq(&add));
    }
    sx
}

/// The lattice point a * floor(s) + v of the sample with weight index 0.
fn coset_base(fac: &Factorisation, sh: &Shapes, v: &[i64], floor: &str) -> String {
    let steps: Vec<i64> = fac.axes.iter().map(|a| a.step).collect();
    let mut jb = format!("{}({floor})", sh.veci);
    if !steps.iter().all(|&a| a == 1) {
        jb = if steps.iter().all(|&a| a == steps[0]) {
            format!("{jb} * {}", steps[0])
        } else {
            format!("{jb} * {}", sh.ivec(&steps))
        };
    }
    if v.iter().any(|&x| x != 0) {
        jb = format!("{jb} + {}", sh.ivec(v));
    }
    jb
}

/// sum_k w_k x_k over non-zero weights.
fn dot(ws: &[String], xs: &[String]) -> String {
    let terms: Vec<String> = ws
        .iter()
        .zip(xs)
        .filter(|(w, _)| *w != "0.0")
        .map(|(w, x)| if w == "1.0" { x.clone() } else { format!("{w} * {x}") })
        .collect();
    if terms.is_empty() {
        "0.0".into()
    } else {
        terms.join(" + ")
    }
}

/// A partially contracted tensor: how often it is differentiated along each
/// axis (all zero: the value) and its entries over the axes not yet
/// contracted (axis-major, first fastest).
struct Tensor {
    deriv: Vec<usize>,
    entries: Vec<String>,
}

/// The body of `<f>_eval` (order 0), `<f>_eval_grad` (order 1) or
/// `<f>_eval_hessian` (order 2) in factored form: each axis contracts with
/// its weights, and (while the total order allows) with their first and
/// second derivatives.
pub(crate) fn emit_factored_body(fac: &Factorisation, sh: &Shapes, name: &str, order: usize) -> String {
    let s = sh.s;
    let mut body = Body::new();
    let orders: Vec<usize> = fac.axes.iter().map(|a| a.order).collect();
    let unit = |i: usize, k: usize| -> Vec<usize> {
        let mut e = vec![0; s];
        e[i] += k;
        e
    };
    // Per coset: the contracted value of each derivative multi-index.
    let mut coset_parts: Vec<Vec<(Vec<usize>, String)>> = Vec::new();
    for v in &fac.cosets {
        let sv = body.bind("s", &coset_coordinate(fac, sh, v, "p"));
        let fl = body.bind("fl", &format!("floor({sv})"));
        let t = body.bind("t", &format!("{sv} - {fl}"));
        let steps: Vec<i64> = fac.axes.iter().map(|a| a.step).collect();
        let jb = body.bind("jb", &coset_base(fac, sh, v, &fl));
        // Weights per axis and derivative order; the scale is folded into the last axis.
        let mut w: Vec<Vec<Vec<String>>> = Vec::new();
        for (i, a) in fac.axes.iter().enumerate() {
            let pows = powers(&mut body, &format!("{t}.{}", AXES[i]), a.order - 1);
            let scale = if i == s - 1 { fac.scale.clone() } else { Q::one() };
            let mut per_k: Vec<Vec<String>> = vec![Vec::new(); order + 1];
            for piece in &a.pieces {
                let mut c: Vec<Q> = piece.iter().map(|x| x.clone() * &scale).collect();
                for (k, wk) in per_k.iter_mut().enumerate() {
                    if k > 0 {
                        // d/dx = (1/a) d/dt.
                        c = (1..c.len()).map(|e| c[e].clone() * Q::int(e as i64) / Q::int(a.step)).collect();
                    }
                    let e = poly_expr(&c, &pows);
                    let prefix = ["wt", "dwt", "ddwt"][k];
                    wk.push(if e.contains(' ') || e.contains('*') { body.bind(prefix, &e) } else { e });
                }
            }
            w.push(per_k);
        }
        // Fetches in odometer order (axis 0 fastest).
        let samples: Vec<String> = odometer(&orders)
            .iter()
            .map(|k| {
                let off: Vec<i64> = (0..s).map(|i| -steps[i] * k[i] as i64).collect();
                let j = if off.iter().all(|&x| x == 0) { jb.clone() } else { format!("{jb} + {}", sh.ivec(&off)) };
                body.bind("f", &format!("{name}_fetch({j})"))
            })
            .collect();
        // Contract axis by axis.
        let mut tensors = vec![Tensor { deriv: vec![0; s], entries: samples }];
        for i in 0..s {
            let n = orders[i];
            let mut next = Vec::new();
            for tz in &tensors {
                let used: usize = tz.deriv.iter().sum();
                for k in 0..=(order - used) {
                    let mut deriv = tz.deriv.clone();
                    deriv[i] = k;
                    let entries: Vec<String> = tz
                        .entries
                        .chunks(n)
                        .map(|xs| {
                            let e = dot(&w[i][k], xs);
                            if e.contains(' ') {
                                body.bind("c", &e)
                            } else {
                                e
                            }
                        })
                        .collect();
                    next.push(Tensor { deriv, entries });
                }
            }
            tensors = next;
        }
        coset_parts.push(tensors.into_iter().map(|t| (t.deriv, t.entries[0].clone())).collect());
    }
    let total = |e: &[usize]| -> String {
        coset_parts
            .iter()
            .map(|parts| {
                parts
                    .iter()
                    .find(|(d, _)| d == e)
                    .map(|(_, x)| x.clone())
                    .expect("every derivative multi-index up to the order is kept through every axis")
            })
            .collect::<Vec<_>>()
            .join(" + ")
    };
    let value = total(&vec![0; s]);
    if order == 0 {
        body.line(&format!("return {value};"));
        return body.text;
    }
    let g: Vec<String> = (0..s).map(|i| total(&unit(i, 1))).collect();
    if order == 1 {
        // Up to 3D the components go straight into vec{s+1}; in 4D into a vec4.
        let g = if s <= 3 { g.join(", ") } else { sh.fvec(&g) };
        body.line(&format!("return {};", sh.grad_result(name, &value, &g)));
        return body.text;
    }
    let value = body.bind("val", &value);
    let g = body.bind("gx", &sh.fvec(&g));
    let entry = |i: usize, j: usize| -> Vec<usize> {
        let mut e = unit(i, 1);
        e[j] += 1;
        e
    };
    let mut upper = vec![String::new(); s * s];
    for i in 0..s {
        for j in i..s {
            let t = total(&entry(i, j));
            upper[i * s + j] = if t.contains(' ') { body.bind("hs", &t) } else { t };
        }
    }
    let cols: Vec<String> =
        (0..s).map(|j| sh.fvec(&(0..s).map(|i| upper[i.min(j) * s + i.max(j)].clone()).collect::<Vec<_>>())).collect();
    let hx = body.bind("hx", &format!("mat{s}x{s}<f32>({})", cols.join(", ")));
    body.line(&format!("return {name}_Hessian({value}, {g}, {hx});"));
    body.text
}

/// `<f>_cube_bounds` for a tensor-product filter: on the unit cube [z, z+1]
/// each coset's part is one tensor polynomial piece per axis, a combination
/// of the samples it fetches with non-negative weights that add up to one
/// over all cosets (box splines are non-negative; partition of unity). So
/// the spline on the cube lies between the least and the greatest of those
/// samples. This helper only serves the min/max kernel, not the evaluation
/// path, so it loops over the samples (scalar accumulators, no arrays) to
/// keep the module small.
pub(crate) fn emit_factored_bounds(fac: &Factorisation, sh: &Shapes, name: &str) -> String {
    if one_piece_per_cube(fac) {
        return emit_tensor_bernstein_bounds(fac, sh, name);
    }
    use std::fmt::Write;
    let s = sh.s;
    let orders: Vec<usize> = fac.axes.iter().map(|a| a.order).collect();
    let total: usize = orders.iter().product();
    let strides: Vec<usize> = (0..s).map(|i| orders[..i].iter().product()).collect();
    let steps: Vec<i64> = fac.axes.iter().map(|a| a.step).collect();
    let mut out = String::new();
    let _ = writeln!(
        out,
        "/// Bounds (min, max) of the spline over the unit cube [z, z+1]: the range of\n/// the samples with non-zero weight there (non-negative weights summing to one).\nfn {name}_cube_bounds(z: {}) -> vec2<f32> {{",
        sh.veci
    );
    let _ = writeln!(out, "    let p = {}(z) + 0.5;", sh.vecf);
    let _ = writeln!(out, "    var lo = 3.4e38;\n    var hi = -3.4e38;");
    let digit = |var: &str, i: usize| format!("(({var} / {}) % {})", strides[i], orders[i]);
    for v in &fac.cosets {
        let _ = writeln!(out, "    {{");
        let fl = format!("floor({})", coset_coordinate(fac, sh, v, "p"));
        let _ = writeln!(out, "        let jb = {};", coset_base(fac, sh, v, &fl));
        let kk: Vec<String> = (0..s).map(|i| digit("k", i)).collect();
        let _ = writeln!(out, "        for (var k = 0; k < {total}; k++) {{");
        let _ = writeln!(
            out,
            "            let c = {name}_fetch(jb - {}({}) * {});",
            sh.veci,
            kk.join(", "),
            sh.ivec(&steps)
        );
        let _ = writeln!(out, "            lo = min(lo, c);\n            hi = max(hi, c);");
        let _ = writeln!(out, "        }}");
        let _ = writeln!(out, "    }}");
    }
    let _ = writeln!(out, "    return vec2<f32>(lo, hi);\n}}");
    out
}

/// `<f>_cube_bounds` for a one-coset tensor-product filter with unit steps
/// and even orders (every unit cube is one polynomial piece, t = frac(s)
/// running over `[0,1]` on each axis): the tensor Bernstein coefficients of
/// that piece, b_I = sum_K prod_i beta_{k_i, I_i} c_K with beta_k the
/// Bernstein coefficients of the weight piece B_n(t + k), bound the spline
/// on the cube (convex hull property). Much tighter than the range of the
/// samples: on smooth data they approach the spline's own range, so fewer
/// cubes straddle an iso-value and the exact hit samples fewer segments.
/// The contraction runs axis by axis (tricubic: 3 x 64 four-term sums).
fn emit_tensor_bernstein_bounds(fac: &Factorisation, sh: &Shapes, name: &str) -> String {
    let s = sh.s;
    let mut body = Body::new();
    let orders: Vec<usize> = fac.axes.iter().map(|a| a.order).collect();
    let v = &fac.cosets[0];
    let p = body.bind("p", &format!("{}(z) + 0.5", sh.vecf));
    let fl = format!("floor({})", coset_coordinate(fac, sh, v, &p));
    let jb = body.bind("jb", &coset_base(fac, sh, v, &fl));
    let mut entries = unit_step_fetches(&mut body, sh, &orders, &jb, name);
    for (i, a) in fac.axes.iter().enumerate() {
        let n = a.order;
        let scale = if i == s - 1 { fac.scale.clone() } else { Q::one() };
        // beta[k][I]: Bernstein coefficient I (degree n - 1) of the weight of sample k.
        let beta: Vec<Vec<Q>> = a
            .pieces
            .iter()
            .map(|piece| {
                let mut c: Vec<Q> = piece.iter().map(|x| x.clone() * &scale).collect();
                c.resize(n, Q::zero());
                bernstein_01(&c)
            })
            .collect();
        let m = entries.len() / n;
        let mut next = vec![String::new(); entries.len()];
        for (ci, xs) in entries.chunks(n).enumerate() {
            for big_i in 0..n {
                let ws: Vec<String> = (0..n).map(|k| lit(&beta[k][big_i])).collect();
                let e = dot(&ws, xs);
                // Contracted axis slowest: the next axis is the fastest one.
                next[ci + big_i * m] = if e.contains(' ') { body.bind("b", &e) } else { e };
            }
        }
        entries = next;
    }
    let mut lo = entries[0].clone();
    let mut hi = entries[0].clone();
    for e in &entries[1..] {
        lo = body.bind("lo", &format!("min({lo}, {e})"));
        hi = body.bind("hi", &format!("max({hi}, {e})"));
    }
    body.line(&format!("return vec2<f32>({lo}, {hi});"));
    format!(
        "/// Bounds (min, max) of the spline over the unit cube [z, z+1]: the range of\n/// its tensor Bernstein coefficients there (convex hull property).\nfn {name}_cube_bounds(z: {}) -> vec2<f32> {{\n{}}}\n",
        sh.veci, body.text
    )
}

/// `<f>_eval` with hardware-filtered fetches (Sigg & Hadwiger's scheme,
/// derived here for any tensor-product filter that
/// [`Factorisation::supports_linear_fetch`]): per axis the non-negative
/// weights of samples k and k+1 become one fetch at f - k - w_{k+1} / g with
/// weight g = w_k + w_{k+1} (a select keeps g = 0 free of a division by
/// zero); the fetches combine as a tensor product of the g.
pub(crate) fn emit_factored_linear_body(fac: &Factorisation, sh: &Shapes, name: &str) -> String {
    let s = sh.s;
    let mut body = Body::new();
    let v = &fac.cosets[0];
    let sv = body.bind("s", &coset_coordinate(fac, sh, v, "p"));
    let fl = body.bind("fl", &format!("floor({sv})"));
    let t = body.bind("t", &format!("{sv} - {fl}"));
    // Texture coordinates: (position + 0.5) / size, with the 0.5 folded in.
    let inv = body.bind("inv", &format!("1.0 / {}({name}_volume_size())", sh.vecf));
    let mut per_axis: Vec<Vec<(String, String)>> = Vec::new(); // (position, weight)
    for (i, a) in fac.axes.iter().enumerate() {
        let pows = powers(&mut body, &format!("{t}.{}", AXES[i]), a.order - 1);
        let scale = if i == s - 1 { fac.scale.clone() } else { Q::one() };
        let w: Vec<String> = a
            .pieces
            .iter()
            .map(|pc| {
                let e = poly_expr(&pc.iter().map(|c| c.clone() * &scale).collect::<Vec<_>>(), &pows);
                if e.contains(' ') || e.contains('*') {
                    body.bind("wt", &e)
                } else {
                    e
                }
            })
            .collect();
        let base = format!("{fl}.{}", AXES[i]);
        let mut fetches = Vec::new();
        let mut k = 0;
        while k < a.order {
            // Sample k sits at f - k; +0.5 moves to the texel centre.
            let pos0 = Q::frac(1, 2) - Q::int(k as i64);
            if k + 1 < a.order {
                let g = body.bind("g", &format!("{} + {}", w[k], w[k + 1]));
                let h = body.bind("h", &format!("select(0.0, {} / {g}, {g} > 0.0)", w[k + 1]));
                let pos = body.bind("x", &format!("({base} + {} - {h}) * {inv}.{}", lit(&pos0), AXES[i]));
                fetches.push((pos, g));
            } else {
                let pos = body.bind("x", &format!("({base} + {}) * {inv}.{}", lit(&pos0), AXES[i]));
                fetches.push((pos, w[k].clone()));
            }
            k += 2;
        }
        per_axis.push(fetches);
    }
    let counts: Vec<usize> = per_axis.iter().map(|f| f.len()).collect();
    let samples: Vec<String> = odometer(&counts)
        .iter()
        .map(|idx| {
            let pos: Vec<String> = (0..s).map(|i| per_axis[i][idx[i]].0.clone()).collect();
            body.bind("f", &format!("{name}_fetch_linear({})", sh.fvec(&pos)))
        })
        .collect();
    // Contract axis by axis with the pair weights g.
    let mut entries = samples;
    for i in 0..s {
        let ws: Vec<String> = per_axis[i].iter().map(|(_, g)| g.clone()).collect();
        entries = entries
            .chunks(counts[i])
            .map(|xs| {
                let e = dot(&ws, xs);
                if e.contains(' ') {
                    body.bind("c", &e)
                } else {
                    e
                }
            })
            .collect();
    }
    body.line(&format!("return {};", entries[0]));
    body.text
}

/// The fetches of a one-coset, unit-step stencil from base `jb`: sample k
/// (odometer order, axis 0 fastest) at jb - k.
fn unit_step_fetches(body: &mut Body, sh: &Shapes, orders: &[usize], jb: &str, name: &str) -> Vec<String> {
    odometer(orders)
        .iter()
        .map(|k| {
            let off: Vec<i64> = k.iter().map(|&x| -(x as i64)).collect();
            let j = if off.iter().all(|&x| x == 0) { jb.to_string() } else { format!("{jb} + {}", sh.ivec(&off)) };
            body.bind("f", &format!("{name}_fetch({j})"))
        })
        .collect()
}

/// Whether every unit cube is one polynomial piece of this tensor-product
/// filter with the local coordinate t = frac(s) running over `[0,1]` per
/// axis: one coset, unit steps, even orders (cc_trilinear, cc_tricubic).
fn one_piece_per_cube(fac: &Factorisation) -> bool {
    fac.cosets.len() == 1 && fac.axes.iter().all(|a| a.step == 1 && a.order % 2 == 0)
}

/// `<f>_ray_bernstein(p0, p1, iso)` for a 3D filter whose unit cubes are
/// single polynomial pieces (one coset, unit steps, even orders), or None
/// for others.
///
/// It returns the Bernstein coefficients, on u in `[0,1]`, of
/// f(p0 + u (p1 - p0)) - iso for a segment inside one cube: the exact first
/// hit gets a whole segment's polynomial from one set of fetches (tricubic:
/// 64) instead of sampling `_eval_grad` at (degree + 1) / 2 points. Along the
/// segment each axis' local coordinate is affine in u, so the weight piece
/// w_k of sample k becomes a polynomial in u of degree n - 1 whose Bernstein
/// coefficients are its blossom (polar form) at (a0 x (n-1-j), a1 x j), with
/// a0, a1 the end coordinates: sum_r c_{k,r} e_r(a0^(n-1-j), a1^j) / C(n-1, r)
/// (e_r the elementary symmetric polynomials of that multiset). The samples
/// contract axis by axis with those weights (times C(n-1, j)), and the
/// product of the three Bernstein bases gives
/// B_j0 B_j1 B_j2 = C(d0,j0) C(d1,j1) C(d2,j2) / C(D, m) B_m with
/// m = j0 + j1 + j2, D the degree.
pub fn ray_bernstein_fn(d: &Derivation, name: &str) -> Option<String> {
    use crate::math::exact::binomial;
    let fac = d.factorisation()?;
    if fac.axes.len() != 3 || !one_piece_per_cube(&fac) {
        return None;
    }
    let sh = Shapes::new(3);
    let s = 3;
    let orders: Vec<usize> = fac.axes.iter().map(|a| a.order).collect();
    let degree: usize = orders.iter().map(|n| n - 1).sum();
    let v = &fac.cosets[0];
    let mut body = Body::new();
    let pm = body.bind("pm", "0.5 * (p0 + p1)");
    let fl = body.bind("fl", &format!("floor({})", coset_coordinate(&fac, &sh, v, &pm)));
    let jb = body.bind("jb", &coset_base(&fac, &sh, v, &fl));
    let a0 = body.bind("a", &format!("{} - {fl}", coset_coordinate(&fac, &sh, v, "p0")));
    let a1 = body.bind("a", &format!("{} - {fl}", coset_coordinate(&fac, &sh, v, "p1")));
    let mut entries = unit_step_fetches(&mut body, &sh, &orders, &jb, name);
    for (i, a) in fac.axes.iter().enumerate() {
        let n = a.order;
        let deg = n - 1;
        let scale = if i == s - 1 { fac.scale.clone() } else { Q::one() };
        let (x0, x1) = (format!("{a0}.{}", AXES[i]), format!("{a1}.{}", AXES[i]));
        let p0s = powers(&mut body, &x0, deg);
        let p1s = powers(&mut body, &x1, deg);
        let pw = |pows: &[String], e: usize| if e == 0 { None } else { Some(pows[e].clone()) };
        // sym[r][j] = e_r(x0 x (deg - j), x1 x j) / C(deg, r), r >= 1.
        let mut sym: Vec<Vec<String>> = vec![vec![]; deg + 1];
        for (r, row) in sym.iter_mut().enumerate().skip(1) {
            for j in 0..=deg {
                let terms: Vec<(Q, String)> = (0..=r)
                    .filter_map(|q| {
                        let c = binomial((deg - j) as u32, (r - q) as u32) * binomial(j as u32, q as u32)
                            / binomial(deg as u32, r as u32);
                        let t = match (pw(&p0s, r - q), pw(&p1s, q)) {
                            (Some(x), Some(y)) => format!("{x} * {y}"),
                            (Some(x), None) | (None, Some(x)) => x,
                            (None, None) => unreachable!("r >= 1"),
                        };
                        (!c.is_zero()).then_some((c, t))
                    })
                    .collect();
                let e = linear_combination(&terms);
                row.push(if e.contains(' ') || e.contains('*') { body.bind("e", &e) } else { e });
            }
        }
        // w[k][j]: C(deg, j) times the blossom of sample k's weight piece.
        let w: Vec<Vec<String>> = a
            .pieces
            .iter()
            .map(|piece| {
                let mut c: Vec<Q> = piece.iter().map(|x| x.clone() * &scale).collect();
                c.resize(n, Q::zero());
                (0..=deg)
                    .map(|j| {
                        let bj = binomial(deg as u32, j as u32);
                        let terms: Vec<(Q, String)> =
                            (1..=deg).map(|r| (c[r].clone() * &bj, sym[r][j].clone())).collect();
                        let mut e = linear_combination(&terms);
                        let c0 = c[0].clone() * &bj;
                        if !c0.is_zero() {
                            e = if e == "0.0" { lit(&c0) } else { format!("{} + {e}", lit(&c0)) };
                        }
                        if e.contains(' ') || e.contains('*') {
                            body.bind("w", &e)
                        } else {
                            e
                        }
                    })
                    .collect()
            })
            .collect();
        let m = entries.len() / n;
        let mut next = vec![String::new(); entries.len()];
        for (ci, xs) in entries.chunks(n).enumerate() {
            for j in 0..n {
                let ws: Vec<String> = (0..n).map(|k| w[k][j].clone()).collect();
                let e = dot(&ws, xs);
                next[ci + j * m] = if e.contains(' ') { body.bind("g", &e) } else { e };
            }
        }
        entries = next;
    }
    // entries: odometer order of (j0, j1, j2).
    let mut by_degree: Vec<Vec<String>> = vec![vec![]; degree + 1];
    for (e, j) in entries.iter().zip(odometer(&orders)) {
        by_degree[j.iter().sum::<usize>()].push(e.clone());
    }
    let coeffs: Vec<String> = by_degree
        .iter()
        .enumerate()
        .map(|(mi, es)| {
            let inv = Q::one() / binomial(degree as u32, mi as u32);
            let sum = es.join(" + ");
            let e = if inv.is_one() { format!("{sum} - iso") } else { format!("{} * ({sum}) - iso", lit(&inv)) };
            body.bind("b", &e)
        })
        .collect();
    body.line(&format!("return array<f32, {}>({});", degree + 1, coeffs.join(", ")));
    Some(format!(
        "/// Bernstein coefficients on u in [0,1] of {name}(p0 + u (p1 - p0)) - iso for\n/// a segment inside one unit cube (one polynomial piece), from one set of\n/// fetches: the blossom of each axis' weights at the segment's ends.\nfn {name}_ray_bernstein(p0: vec3<f32>, p1: vec3<f32>, iso: f32) -> array<f32, {}> {{\n{}}}\n",
        degree + 1,
        body.text
    ))
}
