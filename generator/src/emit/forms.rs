//! Evaluation forms of a reference piece: its coefficients as exact weights
//! of the stencil samples, and their evaluation (de Casteljau for BB, powers
//! for the power form).

use super::writer::*;
use crate::derive::bb::BbForm;
use crate::math::exact::Q;
use crate::math::linalg::{inverse, QVec};
use crate::math::poly::Poly;

/// Coefficients of every monomial (power form) or BB index, as exact weights
/// of the stencil samples: (per coefficient, per stencil index) weights.
pub(crate) enum Form<'a> {
    Bb(&'a BbForm),
    Power(&'a [Poly]),
}

/// Emits the coefficient lets for reference `r`, given the sample names per
/// stencil index. Returns their names (in form order).
pub(crate) fn emit_coefficients(body: &mut Body, weights: &[Vec<Q>], samples: &[String], prefix: &str) -> Vec<String> {
    weights
        .iter()
        .map(|w| {
            let terms: Vec<(Q, String)> = w.iter().cloned().zip(samples.iter().cloned()).collect();
            body.bind(prefix, &linear_combination(&terms))
        })
        .collect()
}

/// Per-coefficient weights of a form: rows = coefficients, columns = stencil.
pub(crate) fn form_weights(form: &Form) -> (Vec<Vec<u32>>, Vec<Vec<Q>>) {
    match form {
        Form::Bb(bb) => (bb.indices.clone(), bb.weights.clone()),
        Form::Power(polys) => {
            let exps = polys[0].basis.exps.clone();
            let rows: Vec<Vec<Q>> =
                (0..exps.len()).map(|e| polys.iter().map(|p| p.coeffs[e].clone()).collect()).collect();
            // Drop monomials that are zero for every sample.
            let keep: Vec<usize> = (0..exps.len()).filter(|&e| rows[e].iter().any(|c| !c.is_zero())).collect();
            (keep.iter().map(|&e| exps[e].clone()).collect(), keep.iter().map(|&e| rows[e].clone()).collect())
        }
    }
}

/// Evaluates a form at local coordinates `u` from its coefficient names,
/// with derivatives up to `order` (0, 1 or 2). Returns (value, gradient in u
/// as a vector expression when order >= 1, Hessian in u as s x s scalar
/// expressions, row-major, when order >= 2).
#[allow(clippy::too_many_arguments)] // one emitter, its inputs are independent
pub(crate) fn emit_form_eval(
    body: &mut Body,
    sh: &Shapes,
    form: &Form,
    indices: &[Vec<u32>],
    coeffs: &[String],
    u: &str,
    order: usize,
    degree: usize,
) -> (String, Option<String>, Vec<String>) {
    let s = sh.s;
    let grad = order >= 1;
    match form {
        Form::Bb(bb) => {
            // Barycentric coordinates: lambda_i = affine(u).
            let v0 = &bb.vertices[0];
            let t: Vec<QVec> = (0..s).map(|j| (1..=s).map(|i| &bb.vertices[i][j] - &v0[j]).collect()).collect();
            let tinv =
                inverse(&t).expect("a simplex's vertices are affinely independent, so its edge matrix is invertible");
            // lambda_i (i>=1) = sum_j tinv[i-1][j] (u_j - v0_j)
            let mut grads: Vec<QVec> = vec![vec![Q::zero(); s]; s + 1];
            let mut consts: Vec<Q> = vec![Q::zero(); s + 1];
            for i in 1..=s {
                grads[i] = tinv[i - 1].clone();
                consts[i] = -crate::math::linalg::dot_q(&tinv[i - 1], v0);
            }
            grads[0] = (0..s).map(|j| -(1..=s).map(|i| grads[i][j].clone()).sum::<Q>()).collect();
            consts[0] = Q::one() - (1..=s).map(|i| consts[i].clone()).sum::<Q>();
            let lam: Vec<String> = (0..=s)
                .map(|i| {
                    let mut terms: Vec<(Q, String)> =
                        (0..s).map(|j| (grads[i][j].clone(), format!("{u}.{}", AXES[j]))).collect();
                    if !consts[i].is_zero() {
                        terms.push((consts[i].clone(), "1.0".into()));
                    }
                    body.bind("l", &linear_combination(&terms))
                })
                .collect();
            if degree == 0 {
                let zeros = if order >= 2 { vec!["0.0".to_string(); s * s] } else { vec![] };
                return (coeffs[0].clone(), grad.then(|| format!("{}(0.0)", sh.vecf)), zeros);
            }
            if order >= 2 && degree == 1 {
                // Linear pieces: the Hessian is zero inside every cell.
                let (v, g, _) = emit_form_eval(body, sh, form, indices, coeffs, u, 1, degree);
                return (v, g, vec!["0.0".to_string(); s * s]);
            }
            // de Casteljau down to degree 1.
            const LEVEL: &str =
                "level holds every multi-index of degree l + 1 (the BB indices, then each step's lower level)";
            let mut level: Vec<(Vec<u32>, String)> = indices.iter().cloned().zip(coeffs.iter().cloned()).collect();
            // The degree-2 level: its coefficients c_{e_i + e_j} give the Hessian,
            // d (d - 1) sum_ij c_{e_i + e_j} grad(lambda_i) grad(lambda_j)^T.
            let mut level2 = (degree == 2).then(|| level.clone());
            for l in (1..degree).rev() {
                let lower: Vec<Vec<u32>> = crate::math::poly::Monomials::get(s + 1, l)
                    .exps
                    .iter()
                    .filter(|e| e.iter().sum::<u32>() as usize == l)
                    .cloned()
                    .collect();
                let mut next = Vec::new();
                for beta in lower {
                    let parts: Vec<String> = (0..=s)
                        .map(|i| {
                            let mut a = beta.clone();
                            a[i] += 1;
                            let name = &level.iter().find(|(e, _)| *e == a).expect(LEVEL).1;
                            format!("{} * {name}", lam[i])
                        })
                        .collect();
                    let n = body.bind("dc", &parts.join(" + "));
                    next.push((beta, n));
                }
                level = next;
                if l == 2 {
                    level2 = Some(level.clone());
                }
            }
            let unit = |i: usize| -> String {
                let mut a = vec![0u32; s + 1];
                a[i] = 1;
                level.iter().find(|(e, _)| *e == a).expect(LEVEL).1.clone()
            };
            let value =
                body.bind("v", &(0..=s).map(|i| format!("{} * {}", lam[i], unit(i))).collect::<Vec<_>>().join(" + "));
            let g = grad.then(|| {
                let comps: Vec<String> = (0..s)
                    .map(|j| {
                        let terms: Vec<(Q, String)> = (0..=s).map(|i| (grads[i][j].clone(), unit(i))).collect();
                        format!("({})", linear_combination(&terms))
                    })
                    .collect();
                body.bind("g", &format!("{} * {}", flit(degree as f32), sh.fvec(&comps)))
            });
            let mut hess = Vec::new();
            if order >= 2 {
                let level2 = level2.expect("degree >= 2 passes through the degree-2 level");
                let c2 = |i: usize, j: usize| -> String {
                    let mut a = vec![0u32; s + 1];
                    a[i] += 1;
                    a[j] += 1;
                    level2.iter().find(|(e, _)| *e == a).expect(LEVEL).1.clone()
                };
                // t[j][p] = sum_i d(lambda_i)/du_p c_{e_i + e_j}.
                let t: Vec<Vec<String>> = (0..=s)
                    .map(|j| {
                        (0..s)
                            .map(|p| {
                                let terms: Vec<(Q, String)> =
                                    (0..=s).map(|i| (grads[i][p].clone(), c2(i, j))).collect();
                                let e = linear_combination(&terms);
                                if e == "0.0" {
                                    e
                                } else {
                                    body.bind("ht", &e)
                                }
                            })
                            .collect()
                    })
                    .collect();
                let scale = Q::int((degree * (degree - 1)) as i64);
                let mut upper = vec![String::new(); s * s];
                for p in 0..s {
                    for q in p..s {
                        let terms: Vec<(Q, String)> = (0..=s)
                            .filter(|&j| t[j][p] != "0.0")
                            .map(|j| (&grads[j][q] * &scale, t[j][p].clone()))
                            .collect();
                        let e = linear_combination(&terms);
                        upper[p * s + q] = if e == "0.0" { e } else { body.bind("hs", &e) };
                    }
                }
                hess = (0..s * s)
                    .map(|i| if i / s <= i % s { upper[i].clone() } else { upper[(i % s) * s + i / s].clone() })
                    .collect();
            }
            (value, g, hess)
        }
        Form::Power(_) if order >= 2 => {
            let vars: Vec<String> = (0..s).map(|i| format!("{u}.{}", AXES[i])).collect();
            let monomials: Vec<(Vec<u32>, String)> = indices.iter().cloned().zip(coeffs.iter().cloned()).collect();
            let (v, g, h) = crate::emit::horner::emit_horner(body, &monomials, &vars, order);
            let v = body.bind("v", &v);
            let g = body.bind("g", &sh.fvec(&g));
            (v, Some(g), h)
        }
        Form::Power(_) => {
            // Powers of each coordinate, then monomials.
            let maxdeg = indices.iter().flat_map(|e| e.iter()).copied().max().unwrap_or(0) as usize;
            let mut pows: Vec<Vec<String>> = Vec::new();
            for j in 0..s {
                let mut p = vec!["1.0".to_string(), format!("{u}.{}", AXES[j])];
                for k in 2..=maxdeg {
                    let n = body.bind("pw", &format!("{} * {u}.{}", p[k - 1], AXES[j]));
                    p.push(n);
                }
                pows.push(p);
            }
            let mono = |e: &[u32], skip: Option<usize>| -> Option<String> {
                let mut f: Vec<String> = Vec::new();
                for j in 0..s {
                    let k = if Some(j) == skip { e[j] as i64 - 1 } else { e[j] as i64 };
                    if k < 0 {
                        return None;
                    }
                    if k > 0 {
                        f.push(pows[j][k as usize].clone());
                    }
                }
                Some(if f.is_empty() { "1.0".to_string() } else { f.join(" * ") })
            };
            let terms: Vec<String> = indices
                .iter()
                .zip(coeffs)
                .map(|(e, c)| {
                    let m = mono(e, None)
                        .expect("mono returns None only when a skipped exponent is 0, and nothing is skipped");
                    if m == "1.0" {
                        c.clone()
                    } else {
                        format!("{c} * {m}")
                    }
                })
                .collect();
            let value = body.bind("v", &sum_or_zero(&terms));
            let g = grad.then(|| {
                let comps: Vec<String> = (0..s)
                    .map(|j| {
                        let t: Vec<String> = indices
                            .iter()
                            .zip(coeffs)
                            .filter_map(|(e, c)| {
                                let m = mono(e, Some(j))?;
                                let k = e[j];
                                Some(if k == 1 {
                                    if m == "1.0" {
                                        c.clone()
                                    } else {
                                        format!("{c} * {m}")
                                    }
                                } else if m == "1.0" {
                                    format!("{} * {c}", flit(k as f32))
                                } else {
                                    format!("{} * {c} * {m}", flit(k as f32))
                                })
                            })
                            .collect();
                        format!("({})", sum_or_zero(&t))
                    })
                    .collect();
                body.bind("g", &sh.fvec(&comps))
            });
            (value, g, vec![])
        }
    }
}
