//! Emission of the linear-form (ridge) form ([`RidgeForm`]): each distinct
//! normal's dot product with u once, each affine form once, powers by
//! repeated squaring, products through a prefix cache, then the sum of
//! weighted products. The gradient comes from the product rule, collected
//! per normal: grad = sum_n n * D_n with D_n = sum over the factors of normal
//! n of p * b_g * L^(p-1) * (the other factors). Scalar straight-line code,
//! so the static op count is what the GPU executes.

use super::writer::{linear_combination, lit, sum_or_zero, Body};
use crate::derive::ridge::RidgeForm;
use crate::math::exact::Q;
use crate::math::linalg::IVec;
use std::collections::{BTreeMap, HashMap};

struct Emitter<'a> {
    ridge: &'a RidgeForm,
    vars: &'a [String],
    dots: HashMap<IVec, String>,
    forms: HashMap<usize, String>,
    powers: HashMap<(usize, u32), String>,
    products: HashMap<Vec<(usize, u32)>, String>,
}

impl Emitter<'_> {
    /// n . u (a coordinate itself for a unit normal).
    fn dot(&mut self, body: &mut Body, n: &IVec) -> String {
        if let Some(d) = self.dots.get(n) {
            return d.clone();
        }
        let nz: Vec<usize> = (0..n.len()).filter(|&i| n[i] != 0).collect();
        let d = if nz.len() == 1 && n[nz[0]] == 1 {
            self.vars[nz[0]].clone()
        } else {
            let terms: Vec<(Q, String)> = nz.iter().map(|&i| (Q::int(n[i]), self.vars[i].clone())).collect();
            body.bind("r", &linear_combination(&terms))
        };
        self.dots.insert(n.clone(), d.clone());
        d
    }

    /// L_f = n_f . u + b_f.
    fn form(&mut self, body: &mut Body, f: usize) -> String {
        if let Some(l) = self.forms.get(&f) {
            return l.clone();
        }
        let a = &self.ridge.affine[f];
        let d = self.dot(body, &a.normal);
        let l = if a.offset.is_zero() {
            d
        } else if a.offset.is_negative() {
            body.bind("l", &format!("{d} - {}", lit(&a.offset.abs())))
        } else {
            body.bind("l", &format!("{d} + {}", lit(&a.offset)))
        };
        self.forms.insert(f, l.clone());
        l
    }

    /// L_f^p, p >= 1 (squaring for even powers).
    fn power(&mut self, body: &mut Body, f: usize, p: u32) -> String {
        if p == 1 {
            return self.form(body, f);
        }
        if let Some(x) = self.powers.get(&(f, p)) {
            return x.clone();
        }
        let x = if p.is_multiple_of(2) {
            let h = self.power(body, f, p / 2);
            body.bind("x", &format!("{h} * {h}"))
        } else {
            let a = self.power(body, f, p - 1);
            let b = self.form(body, f);
            body.bind("x", &format!("{a} * {b}"))
        };
        self.powers.insert((f, p), x.clone());
        x
    }

    /// prod of L_f^p over a sorted factor list; None for the empty product.
    fn product(&mut self, body: &mut Body, factors: &[(usize, u32)]) -> Option<String> {
        match factors {
            [] => None,
            [(f, p)] => Some(self.power(body, *f, *p)),
            [head @ .., (f, p)] => {
                if let Some(x) = self.products.get(factors) {
                    return Some(x.clone());
                }
                let a = self.product(body, head).expect("a non-empty head has a product");
                let b = self.power(body, *f, *p);
                let x = body.bind("pr", &format!("{a} * {b}"));
                self.products.insert(factors.to_vec(), x.clone());
                Some(x)
            }
        }
    }
}

/// `coef * prod`, or `coef` for the empty product.
fn times(coef: &str, prod: Option<String>) -> String {
    match prod {
        Some(p) => format!("{coef} * {p}"),
        None => coef.to_string(),
    }
}

/// Emits s(u) = sum_g m_g(u) * prod_g(u) for the ridge form, with `coeffs`
/// the names of the sample combinations of [`RidgeForm::rows`] (in that
/// order), m_g the group's multiplier (its constant row, plus its linear rows
/// times the coordinates) and `vars` the coordinates of u. Returns (value,
/// gradient components), "0.0" for zeros; the gradient is empty unless `grad`.
pub(crate) fn emit_ridge(
    body: &mut Body,
    ridge: &RidgeForm,
    coeffs: &[String],
    vars: &[String],
    grad: bool,
) -> (String, Vec<String>) {
    let mut e = Emitter {
        ridge,
        vars,
        dots: HashMap::new(),
        forms: HashMap::new(),
        powers: HashMap::new(),
        products: HashMap::new(),
    };
    // Per group: (multiplier name, linear coefficient names by coordinate).
    let mut next = 0;
    type Multiplier = (String, Vec<(usize, String)>);
    let mut mults: Vec<Option<Multiplier>> = Vec::new();
    for g in &ridge.groups {
        let mut constant: Option<String> = None;
        let mut linear: Vec<(usize, String)> = Vec::new();
        for (j, _) in g.rows() {
            let name = coeffs[next].clone();
            next += 1;
            if name == "0.0" {
                continue;
            }
            match j {
                None => constant = Some(name),
                Some(j) => linear.push((j, name)),
            }
        }
        let m = if linear.is_empty() {
            constant
        } else {
            let mut terms: Vec<String> = constant.into_iter().collect();
            terms.extend(linear.iter().map(|(j, b)| format!("{b} * {}", vars[*j])));
            Some(body.bind("m", &terms.join(" + ")))
        };
        mults.push(m.map(|m| (m, linear)));
    }
    assert_eq!(next, coeffs.len(), "one name per row of RidgeForm::rows");
    let live: Vec<usize> = (0..ridge.groups.len()).filter(|&g| mults[g].is_some()).collect();
    let mult = |g: usize| &mults[g].as_ref().expect("live groups have a multiplier").0;
    let terms: Vec<String> = live
        .iter()
        .map(|&g| {
            let p = e.product(body, &ridge.groups[g].factors);
            times(mult(g), p)
        })
        .collect();
    let value = sum_or_zero(&terms);
    if !grad {
        return (value, vec![]);
    }
    // D_n: per normal, per power p, the terms m_g * L^(p-1) * others.
    let mut per_normal: BTreeMap<IVec, BTreeMap<u32, Vec<String>>> = BTreeMap::new();
    // The multipliers' own gradients: b_j * prod_g per coordinate j.
    let mut direct: Vec<Vec<String>> = vec![Vec::new(); vars.len()];
    for &g in &live {
        let factors = &ridge.groups[g].factors;
        for (i, &(f, p)) in factors.iter().enumerate() {
            let mut rest = factors.clone();
            if p == 1 {
                rest.remove(i);
            } else {
                rest[i].1 -= 1;
            }
            let prod = e.product(body, &rest);
            let normal = ridge.affine[f].normal.clone();
            per_normal.entry(normal).or_default().entry(p).or_default().push(times(mult(g), prod));
        }
        let linear = &mults[g].as_ref().expect("live").1;
        if !linear.is_empty() {
            let prod = e.product(body, factors);
            for (j, b) in linear {
                direct[*j].push(times(b, prod.clone()));
            }
        }
    }
    let mut dn: Vec<(IVec, String)> = Vec::new();
    for (n, by_p) in per_normal {
        let parts: Vec<String> = by_p
            .iter()
            .map(|(p, t)| {
                let sum = t.join(" + ");
                match (*p, t.len()) {
                    (1, _) => sum,
                    (p, 1) => format!("{} * {sum}", lit(&Q::int(p as i64))),
                    (p, _) => format!("{} * ({sum})", lit(&Q::int(p as i64))),
                }
            })
            .collect();
        dn.push((n, body.bind("dn", &parts.join(" + "))));
    }
    let g: Vec<String> = (0..vars.len())
        .map(|j| {
            let terms: Vec<(Q, String)> = dn.iter().map(|(n, d)| (Q::int(n[j]), d.clone())).collect();
            let lc = linear_combination(&terms);
            match (lc.as_str(), direct[j].is_empty()) {
                (_, true) => lc,
                ("0.0", false) => direct[j].join(" + "),
                _ => format!("{lc} + {}", direct[j].join(" + ")),
            }
        })
        .collect();
    (value, g)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::derive::Derivation;
    use crate::emit::cse::LinearMap;
    use crate::spec::catalog;
    use std::collections::HashMap;

    /// Evaluates an expression of + - * ( ), unary minus, literals and names.
    fn expr(src: &str, env: &HashMap<String, f64>) -> f64 {
        let toks = tokenize(src);
        let mut pos = 0;
        let v = sum(&toks, &mut pos, env);
        assert_eq!(pos, toks.len(), "trailing tokens in {src}");
        v
    }

    fn tokenize(src: &str) -> Vec<String> {
        let c: Vec<char> = src.chars().collect();
        let mut out = Vec::new();
        let mut i = 0;
        while i < c.len() {
            let ch = c[i];
            if ch == ' ' {
                i += 1;
            } else if "+-*()".contains(ch) {
                out.push(ch.to_string());
                i += 1;
            } else {
                let start = i;
                while i < c.len()
                    && (c[i].is_alphanumeric()
                        || c[i] == '_'
                        || c[i] == '.'
                        || ((c[i] == '-' || c[i] == '+')
                            && (c[i - 1] == 'e' || c[i - 1] == 'E')
                            && c[start].is_ascii_digit()))
                {
                    i += 1;
                }
                assert!(i > start, "unexpected {ch:?} in {src}");
                out.push(c[start..i].iter().collect());
            }
        }
        out
    }

    fn sum(t: &[String], pos: &mut usize, env: &HashMap<String, f64>) -> f64 {
        let mut v = prod(t, pos, env);
        while *pos < t.len() && (t[*pos] == "+" || t[*pos] == "-") {
            let neg = t[*pos] == "-";
            *pos += 1;
            let r = prod(t, pos, env);
            v = if neg { v - r } else { v + r };
        }
        v
    }

    fn prod(t: &[String], pos: &mut usize, env: &HashMap<String, f64>) -> f64 {
        let mut v = atom(t, pos, env);
        while *pos < t.len() && t[*pos] == "*" {
            *pos += 1;
            v *= atom(t, pos, env);
        }
        v
    }

    fn atom(t: &[String], pos: &mut usize, env: &HashMap<String, f64>) -> f64 {
        let tok = t[*pos].clone();
        *pos += 1;
        match tok.as_str() {
            "-" => -atom(t, pos, env),
            "(" => {
                let v = sum(t, pos, env);
                assert_eq!(t[*pos], ")");
                *pos += 1;
                v
            }
            name => env.get(name).copied().unwrap_or_else(|| name.parse().unwrap_or_else(|_| panic!("unbound {name}"))),
        }
    }

    fn run(text: &str, env: &mut HashMap<String, f64>) {
        for line in text.lines() {
            let line = line.trim();
            let rest = line.strip_prefix("let ").expect("only let bindings").strip_suffix(';').unwrap();
            let (name, e) = rest.split_once(" = ").unwrap();
            let v = expr(e, env);
            env.insert(name.to_string(), v);
        }
    }

    /// The emitted code (sample combinations + ridge evaluation) computes the
    /// spline and its gradient: checked against the exact stencil polynomials.
    #[test]
    fn emitted_ridge_code_evaluates_the_piece_and_its_gradient() {
        for name in ["bcc7", "fcc6", "courant", "zp", "bcc_linear"] {
            let d = Derivation::new(&catalog::get(name).unwrap()).unwrap();
            let s = d.facts.dim;
            let vars: Vec<String> = (0..s).map(|i| format!("u{i}")).collect();
            for r in 0..d.references.len() {
                let merged = d.ridge(r).merged();
                for ridge in [d.ridge(r), &merged] {
                    let polys = &d.forms(r).polys;
                    let nst = polys.len();
                    let samples: Vec<String> = (0..nst).map(|k| format!("c{k}")).collect();
                    let weights = ridge.rows();
                    let mut body = Body::new();
                    let coeffs = LinearMap::shared(&weights).emit(&mut body, &samples, "b");
                    let (v, g) = emit_ridge(&mut body, ridge, &coeffs, &vars, true);
                    let vn = body.bind("v", &v);
                    let gn: Vec<String> = g.iter().map(|x| body.bind("g", x)).collect();
                    assert!(!body.text.contains("if") && !body.text.contains("for"), "straight-line code");
                    for trial in 0..3 {
                        let mut env = HashMap::new();
                        let cs: Vec<f64> = (0..nst).map(|k| ((k * 7 + trial * 3) % 11) as f64 / 5.0 - 1.0).collect();
                        for k in 0..nst {
                            env.insert(samples[k].clone(), cs[k]);
                        }
                        // A point of the reference cell: its interior, in local coordinates.
                        let c = &d.arrangement.cells[d.references[r].cell];
                        let origin = d.cube_origin(&d.references[r].corner);
                        let uq: Vec<Q> =
                            (0..s).map(|i| &c.interior[i] - &origin[i] + Q::frac(trial as i64, 97)).collect();
                        let u: Vec<f64> = uq.iter().map(|x| x.to_f64()).collect();
                        for i in 0..s {
                            env.insert(vars[i].clone(), u[i]);
                        }
                        run(&body.text, &mut env);
                        let mut want = 0.0;
                        let mut want_g = vec![0.0; s];
                        for k in 0..nst {
                            want += cs[k] * polys[k].eval(&uq).to_f64();
                            for j in 0..s {
                                want_g[j] += cs[k] * polys[k].derivative(j).eval(&uq).to_f64();
                            }
                        }
                        // The literals are f32 (as in the shader): about 1e-7 relative.
                        assert!((env[&vn] - want).abs() < 1e-6, "{name} piece {r}: {} vs {want}", env[&vn]);
                        for j in 0..s {
                            let (got, w) = (env[&gn[j]], want_g[j]);
                            assert!((got - w).abs() < 1e-6, "{name} piece {r} d/du{j}: {got} vs {w}");
                        }
                    }
                }
            }
        }
    }

    #[test]
    fn the_expression_evaluator_reads_what_the_writer_writes() {
        let env: HashMap<String, f64> = [("a".to_string(), 2.0), ("b".to_string(), 3.0)].into_iter().collect();
        assert_eq!(expr("-a + 0.5 * (b - a) * 4.0 - 1e-1", &env), -2.0 + 2.0 - 0.1);
    }
}
