//! Nested Horner evaluation of a polynomial whose monomial coefficients are
//! runtime values (named WGSL expressions), with the gradient carried along
//! (and the second partials) in forward mode when asked: P = sum_i u_0^i P_i(u_1, ...), each P_i by
//! the same rule in the next variable. Written in scalar code so the static
//! op count is what the GPU executes.

use super::writer::Body;
use std::collections::BTreeMap;

/// A value with its partial derivatives (and second partials, `h[j * s + l]`
/// for j <= l, when asked); `None` is an exact zero.
#[derive(Clone, Debug)]
struct Dual {
    v: Option<String>,
    d: Vec<Option<String>>,
    h: Vec<Option<String>>,
}

impl Dual {
    fn zero(s: usize) -> Dual {
        Dual { v: None, d: vec![None; s], h: vec![None; s * s] }
    }
}

/// `a * x + sum(adds)` with zeros folded away.
fn mul_add(body: &mut Body, a: &Option<String>, x: &str, adds: &[Option<String>]) -> Option<String> {
    let mut terms: Vec<String> = Vec::new();
    if let Some(a) = a {
        terms.push(format!("{a} * {x}"));
    }
    terms.extend(adds.iter().flatten().cloned());
    match terms.len() {
        0 => None,
        1 if a.is_none() => Some(terms.remove(0)),
        _ => Some(body.bind("h", &terms.join(" + "))),
    }
}

/// Horner over variables `vars[k..]` for the monomials in `coeffs`
/// (exponents restricted to those variables), carrying derivatives up to `order`.
fn horner_rec(body: &mut Body, coeffs: &BTreeMap<Vec<u32>, String>, vars: &[String], k: usize, order: usize) -> Dual {
    let s = vars.len();
    if k == s {
        let mut z = Dual::zero(s);
        z.v = coeffs.get(&vec![0u32; s]).cloned();
        return z;
    }
    // Group by the exponent of variable k.
    let mut groups: BTreeMap<u32, BTreeMap<Vec<u32>, String>> = BTreeMap::new();
    for (e, c) in coeffs {
        let mut rest = e.clone();
        rest[k] = 0;
        groups.entry(e[k]).or_default().insert(rest, c.clone());
    }
    let Some(&top) = groups.keys().next_back() else {
        return Dual::zero(s);
    };
    let inner: BTreeMap<u32, Dual> =
        groups.iter().map(|(i, g)| (*i, horner_rec(body, g, vars, k + 1, order))).collect();
    let x = &vars[k];
    let mut acc = inner[&top].clone();
    for i in (0..top).rev() {
        let p = inner.get(&i).cloned().unwrap_or_else(|| Dual::zero(s));
        let mut next = Dual::zero(s);
        // acc' = acc x + p, where p and acc's inner parts do not depend on u_k.
        if order >= 2 {
            for j in 0..s {
                for l in j..s {
                    // d2/du_j du_l (acc x + p) = (d2 acc) x + [j == k] d_l acc + [l == k] d_j acc + d2 p.
                    let mut adds = vec![p.h[j * s + l].clone()];
                    if j == k {
                        adds.push(acc.d[l].clone());
                    }
                    if l == k {
                        adds.push(acc.d[j].clone());
                    }
                    next.h[j * s + l] = mul_add(body, &acc.h[j * s + l], x, &adds);
                }
            }
        }
        if order >= 1 {
            for j in 0..s {
                // d/du_k (acc x + p) = (d acc) x + acc; other variables: (d acc) x + d p.
                let add = if j == k { acc.v.clone() } else { p.d[j].clone() };
                next.d[j] = mul_add(body, &acc.d[j], x, &[add]);
            }
        }
        next.v = mul_add(body, &acc.v, x, std::slice::from_ref(&p.v));
        acc = next;
    }
    acc
}

/// Emits P(u) = sum_e c_e u^e. Returns (value, gradient components, Hessian
/// entries row-major s x s) as expressions ("0.0" for zeros); the gradient is
/// empty unless `order >= 1`, the Hessian unless `order >= 2`.
pub(crate) fn emit_horner(
    body: &mut Body,
    monomials: &[(Vec<u32>, String)],
    vars: &[String],
    order: usize,
) -> (String, Vec<String>, Vec<String>) {
    let s = vars.len();
    let coeffs: BTreeMap<Vec<u32>, String> =
        monomials.iter().filter(|(_, c)| c != "0.0").map(|(e, c)| (e.clone(), c.clone())).collect();
    let d = horner_rec(body, &coeffs, vars, 0, order);
    let z = |e: &Option<String>| e.clone().unwrap_or_else(|| "0.0".into());
    let g = if order >= 1 { d.d.iter().map(z).collect() } else { vec![] };
    let h = if order >= 2 {
        (0..s * s).map(|i| if i / s <= i % s { z(&d.h[i]) } else { z(&d.h[(i % s) * s + i / s]) }).collect()
    } else {
        vec![]
    };
    (z(&d.v), g, h)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Evaluates straight-line `let` code with + and * on scalars (enough for
    /// Horner output) to check it numerically.
    fn run(text: &str, env: &mut std::collections::HashMap<String, f64>) {
        for line in text.lines() {
            let line = line.trim().trim_start_matches("let ").trim_end_matches(';');
            let (name, expr) = line.split_once(" = ").unwrap();
            let v: f64 = expr
                .split(" + ")
                .map(|t| {
                    t.split(" * ").map(|f| env.get(f).copied().unwrap_or_else(|| f.parse().unwrap())).product::<f64>()
                })
                .sum();
            env.insert(name.to_string(), v);
        }
    }

    #[test]
    fn horner_matches_the_monomial_sum_and_its_gradient() {
        let exps: Vec<Vec<u32>> =
            vec![vec![0, 0, 0], vec![1, 0, 0], vec![0, 2, 1], vec![3, 1, 0], vec![2, 0, 2], vec![0, 0, 4]];
        let coef = [1.5, -2.0, 0.25, 3.0, -1.0, 0.5];
        let u = [0.3, 0.7, 0.2];
        let monomials: Vec<(Vec<u32>, String)> =
            exps.iter().enumerate().map(|(i, e)| (e.clone(), format!("c{i}"))).collect();
        let vars: Vec<String> = ["ux", "uy", "uz"].iter().map(|s| s.to_string()).collect();
        let mut body = Body::new();
        let (v, g, h) = emit_horner(&mut body, &monomials, &vars, 2);
        let mut env = std::collections::HashMap::new();
        for (i, c) in coef.iter().enumerate() {
            env.insert(format!("c{i}"), *c);
        }
        for (n, x) in vars.iter().zip(u) {
            env.insert(n.clone(), x);
        }
        run(&body.text, &mut env);
        let get = |e: &str, env: &std::collections::HashMap<String, f64>| {
            env.get(e).copied().unwrap_or_else(|| e.parse().unwrap())
        };
        let (want, want_g) = crate::math::poly::eval_poly_f64(&exps, &coef, &u);
        assert!((get(&v, &env) - want).abs() < 1e-12);
        for j in 0..3 {
            assert!((get(&g[j], &env) - want_g[j]).abs() < 1e-12, "d/du{j}");
        }
        // Second partials by central differences of the exact gradient (a cubic-exact rule).
        let eps = 1e-4;
        for j in 0..3 {
            for l in 0..3 {
                let mut up = u;
                let mut dn = u;
                up[l] += eps;
                dn[l] -= eps;
                let fd = (crate::math::poly::eval_poly_f64(&exps, &coef, &up).1[j]
                    - crate::math::poly::eval_poly_f64(&exps, &coef, &dn).1[j])
                    / (2.0 * eps);
                assert!((get(&h[j * 3 + l], &env) - fd).abs() < 1e-6, "d2/du{j}du{l}");
            }
        }
    }
}
