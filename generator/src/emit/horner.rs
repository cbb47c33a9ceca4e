//! Nested Horner evaluation of a polynomial whose monomial coefficients are
//! runtime values (named WGSL expressions), with the gradient carried along
//! in forward mode when asked: P = sum_i u_0^i P_i(u_1, ...), each P_i by
//! the same rule in the next variable. Written in scalar code so the static
//! op count is what the GPU executes.

use super::writer::Body;
use std::collections::BTreeMap;

/// A value with its partial derivatives; `None` is an exact zero.
#[derive(Clone, Debug)]
struct Dual {
    v: Option<String>,
    d: Vec<Option<String>>,
}

/// `a * x + b` with zeros folded away.
fn mul_add(body: &mut Body, a: &Option<String>, x: &str, b: &Option<String>) -> Option<String> {
    match (a, b) {
        (None, None) => None,
        (None, Some(b)) => Some(b.clone()),
        (Some(a), None) => Some(body.bind("h", &format!("{a} * {x}"))),
        (Some(a), Some(b)) => Some(body.bind("h", &format!("{a} * {x} + {b}"))),
    }
}

/// Horner over variables `vars[k..]` for the monomials in `coeffs`
/// (exponents restricted to those variables).
fn horner_rec(body: &mut Body, coeffs: &BTreeMap<Vec<u32>, String>, vars: &[String], k: usize, grad: bool) -> Dual {
    let s = vars.len();
    if k == s {
        let v = coeffs.get(&vec![0u32; s]).cloned();
        return Dual { v, d: vec![None; s] };
    }
    // Group by the exponent of variable k.
    let mut groups: BTreeMap<u32, BTreeMap<Vec<u32>, String>> = BTreeMap::new();
    for (e, c) in coeffs {
        let mut rest = e.clone();
        rest[k] = 0;
        groups.entry(e[k]).or_default().insert(rest, c.clone());
    }
    let Some(&top) = groups.keys().next_back() else {
        return Dual { v: None, d: vec![None; s] };
    };
    let inner: BTreeMap<u32, Dual> = groups.iter().map(|(i, g)| (*i, horner_rec(body, g, vars, k + 1, grad))).collect();
    let x = &vars[k];
    let mut acc = inner[&top].clone();
    for i in (0..top).rev() {
        let p = inner.get(&i).cloned().unwrap_or(Dual { v: None, d: vec![None; s] });
        let mut next = Dual { v: None, d: vec![None; s] };
        if grad {
            for j in 0..s {
                // d/du_k (acc x + p) = (d acc) x + acc; other variables: (d acc) x + d p.
                let add = if j == k { acc.v.clone() } else { p.d[j].clone() };
                next.d[j] = mul_add(body, &acc.d[j], x, &add);
            }
        }
        next.v = mul_add(body, &acc.v, x, &p.v);
        acc = next;
    }
    acc
}

/// Emits P(u) = sum_e c_e u^e. Returns (value, gradient components) as
/// expressions ("0.0" for zeros); the gradient is empty unless `grad`.
pub(crate) fn emit_horner(
    body: &mut Body,
    monomials: &[(Vec<u32>, String)],
    vars: &[String],
    grad: bool,
) -> (String, Vec<String>) {
    let coeffs: BTreeMap<Vec<u32>, String> =
        monomials.iter().filter(|(_, c)| c != "0.0").map(|(e, c)| (e.clone(), c.clone())).collect();
    let d = horner_rec(body, &coeffs, vars, 0, grad);
    let z = |e: Option<String>| e.unwrap_or_else(|| "0.0".into());
    let g = if grad { d.d.into_iter().map(z).collect() } else { vec![] };
    (z(d.v), g)
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
        let (v, g) = emit_horner(&mut body, &monomials, &vars, true);
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
    }
}
