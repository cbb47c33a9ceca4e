//! Hardware-filtered (linear) fetches for the plan-based forms, on the
//! packed layout (docs/EVALUATION_FORMS.md §4).
//!
//! Every weight of s(x) = sum_j c_j phi(x - j) is a value of the box spline,
//! so it is >= 0 (a box spline is the volume of a slice of a cube). Two
//! samples of one coset of 2Z^s that differ by 2 e_i are adjacent texels of
//! that coset's grid, so a linear sampler returns (1 - t) c_a + t c_b at the
//! texel position m_a + t (m_b - m_a): the pair costs one fetch at
//! t = w_b / (w_a + w_b), times w_a + w_b. The pairs are a maximum matching
//! of the reference stencil's adjacency graph (bipartite: the grid parity of
//! a coset point flips along every edge), found once per reference in exact
//! integer arithmetic; the fold maps stencils by signed permutations, which
//! keep adjacent texels adjacent.
//!
//! The cosets are tiles of the one packed texture the exact fetch reads
//! (bound as filterable): coset c's grid is offset by the grid size along
//! each pivot axis whose parity bit is set, so the tile is arithmetic on the
//! parity of j (as in the exact fetch), never a choice between textures.
//! Clamping each texel to its tile before interpolating reproduces the exact
//! loads' clamp-to-edge.

use super::locate::{emit_candidate_choice, emit_frame, local_coords, select_by_candidate, Fast, Frame};
use super::writer::{Body, Shapes, AXES};
use crate::derive::Derivation;
use crate::emit::plan::Plan;
use crate::math::exact::{binomial, Q};
use crate::math::linalg::{IVec, QVec};
use crate::math::poly::Poly;
use serde::Serialize;
use std::collections::BTreeMap;

/// One fetch of a reference: stencil index `a`, paired with `b` (b = a + 2 e_i) or alone.
pub type FetchSlot = (usize, Option<usize>);

/// Which stencil samples share a filtered fetch, per reference piece.
#[derive(Clone, Debug)]
pub struct LinearPlan {
    /// Per reference: its fetch slots (pairs first, then single samples).
    pub slots: Vec<Vec<FetchSlot>>,
    /// How the weights were shown to be non-negative.
    pub proof: NonNegativity,
}

/// Exact evidence that the fetch weights are non-negative on their pieces.
#[derive(Clone, Debug, Serialize, PartialEq, Eq)]
pub struct NonNegativity {
    /// Weights (reference pieces x stencil samples) in all.
    pub weights: usize,
    /// Weights whose Bernstein-Bezier coefficients on their piece (a simplex,
    /// or tensor-product ones on a box) are all >= 0, checked exactly:
    /// non-negative on the piece by that alone.
    pub by_bernstein_coefficients: usize,
    /// The rest are non-negative because box splines are (theorem); the
    /// emitted code clamps t to [0, 1] against rounding either way.
    pub by_box_spline_theorem: usize,
}

impl LinearPlan {
    /// The pairing of every reference's stencil (a maximum matching).
    pub fn new(d: &Derivation) -> LinearPlan {
        let mut slots = Vec::new();
        let (mut weights, mut bernstein) = (0, 0);
        for (ri, r) in d.references.iter().enumerate() {
            slots.push(pair_stencil(&r.stencil));
            weights += r.stencil.len();
            let forms = d.forms(ri);
            if let Some(bb) = &forms.bb {
                bernstein +=
                    (0..r.stencil.len()).filter(|&k| bb.weights.iter().all(|row| !row[k].is_negative())).count();
            } else if let Some((lo, hi)) = box_bounds(&r.vertices, &d.cube_origin(&r.corner)) {
                bernstein += forms.polys.iter().filter(|p| tensor_bernstein_non_negative(p, &lo, &hi)).count();
            }
        }
        LinearPlan {
            slots,
            proof: NonNegativity {
                weights,
                by_bernstein_coefficients: bernstein,
                by_box_spline_theorem: weights - bernstein,
            },
        }
    }

    /// Filtered fetches per evaluation: the most slots any used reference needs.
    pub fn fetches(&self, plan: &Plan) -> usize {
        plan.used_references().iter().map(|&r| self.slots[r].len()).max().unwrap_or(0)
    }

    /// CPU mirror of the emitted linear eval, as a GPU computes it: the
    /// plan's frame and candidate, the weights at the local coordinates,
    /// one interpolation per slot along its pair's axis, with the fraction
    /// rounded to `frac_bits` bits (None: exact, as lavapipe filters).
    pub fn eval_f64(
        &self,
        d: &Derivation,
        plan: &Plan,
        x: &[f64],
        data: &dyn Fn(&[i64]) -> f64,
        frac_bits: Option<u32>,
    ) -> f64 {
        let s = plan.dim;
        let at = plan.locate_f64(d, x);
        let (c, u) = (&plan.candidates[at.candidate], &at.u);
        let pos_of = |k: usize| plan.stencil_position(&at, k);
        let tab = d.f64_reference(c.reference);
        let w: Vec<f64> =
            tab.coeffs.iter().map(|coeffs| crate::math::poly::eval_poly_f64(&tab.exps, coeffs, u).0).collect();
        let mut total = 0.0;
        for &(a, b) in &self.slots[c.reference] {
            let ja = pos_of(a);
            let Some(b) = b else {
                total += w[a] * data(&ja);
                continue;
            };
            let jb = pos_of(b);
            let sum = w[a] + w[b];
            let t = (w[b] / sum.max(1e-30)).clamp(0.0, 1.0);
            // The hardware: texels floor(m - 1/2 + 1/2) .. + 1 along the pair's axis.
            let axis = (0..s).find(|&i| ja[i] != jb[i]).expect("paired samples differ along one axis");
            let (lo, hi, f) = if jb[axis] > ja[axis] { (&ja, &jb, t) } else { (&jb, &ja, 1.0 - t) };
            let f = match frac_bits {
                Some(bits) => (f * (1u64 << bits) as f64).round() / (1u64 << bits) as f64,
                None => f,
            };
            total += sum * ((1.0 - f) * data(lo) + f * data(hi));
        }
        total
    }
}

/// The piece's box [lo, hi] in local coordinates, when its vertices are
/// exactly the 2^s corners of their bounding box.
fn box_bounds(vertices: &[QVec], origin: &[Q]) -> Option<(QVec, QVec)> {
    let s = origin.len();
    let local: Vec<QVec> = vertices.iter().map(|v| (0..s).map(|i| &v[i] - &origin[i]).collect()).collect();
    let lo: QVec = (0..s).map(|i| local.iter().map(|v| v[i].clone()).min().expect("a piece has vertices")).collect();
    let hi: QVec = (0..s).map(|i| local.iter().map(|v| v[i].clone()).max().expect("a piece has vertices")).collect();
    let corners = local.iter().all(|v| (0..s).all(|i| v[i] == lo[i] || v[i] == hi[i]));
    let distinct: std::collections::BTreeSet<&QVec> = local.iter().collect();
    (corners && distinct.len() == 1 << s && (0..s).all(|i| lo[i] < hi[i])).then_some((lo, hi))
}

/// Whether every tensor-product Bernstein coefficient of p on the box
/// [lo, hi] (degree n per variable, n = p's total degree) is >= 0, exactly.
fn tensor_bernstein_non_negative(p: &Poly, lo: &[Q], hi: &[Q]) -> bool {
    let s = lo.len();
    let n = p.basis.degree;
    let side = n + 1;
    let mut a = vec![Q::zero(); side.pow(s as u32)];
    let flat = |e: &[usize]| e.iter().rev().fold(0, |acc, &x| acc * side + x);
    for (e, c) in p.basis.exps.iter().zip(&p.coeffs) {
        let e: Vec<usize> = e.iter().map(|&x| x as usize).collect();
        a[flat(&e)] = c.clone();
    }
    // Power -> Bernstein on [0, 1], the same for every fibre: b_k = sum_j c_j C(k,j)/C(n,j).
    let to_bernstein: Vec<Vec<Q>> = (0..side)
        .map(|k| (0..=k).map(|j| binomial(k as u32, j as u32) / binomial(n as u32, j as u32)).collect())
        .collect();
    for axis in 0..s {
        let stride = side.pow(axis as u32);
        let h = &hi[axis] - &lo[axis];
        // q(lo + h t) in powers of t: c_j = sum_k a_k C(k,j) lo^(k-j) h^j, one table per axis.
        let shift: Vec<Vec<Q>> = (0..side)
            .map(|k| {
                (0..=k).map(|j| binomial(k as u32, j as u32) * lo[axis].pow((k - j) as u32) * h.pow(j as u32)).collect()
            })
            .collect();
        for start in 0..a.len() {
            if !(start / stride).is_multiple_of(side) {
                continue; // not the first entry of a fibre along this axis
            }
            let fibre: Vec<Q> = (0..side).map(|k| a[start + k * stride].clone()).collect();
            if fibre.iter().all(Q::is_zero) {
                continue;
            }
            let mut c = vec![Q::zero(); side];
            for (k, ak) in fibre.iter().enumerate() {
                if ak.is_zero() {
                    continue;
                }
                for (j, cj) in c.iter_mut().enumerate().take(k + 1) {
                    *cj += &(ak * &shift[k][j]);
                }
            }
            for k in 0..side {
                let b: Q = (0..=k).filter(|&j| !c[j].is_zero()).map(|j| &c[j] * &to_bernstein[k][j]).sum();
                a[start + k * stride] = b;
            }
        }
    }
    a.iter().all(|b| !b.is_negative())
}

/// A maximum matching of stencil points that differ by 2 e_i (Kuhn's
/// augmenting paths from the even side, in stencil order: deterministic).
/// Returns the pairs (lower point first), then the unmatched points.
fn pair_stencil(stencil: &[IVec]) -> Vec<FetchSlot> {
    let index: BTreeMap<&IVec, usize> = stencil.iter().enumerate().map(|(i, k)| (k, i)).collect();
    let s = stencil.first().map_or(0, |k| k.len());
    // Grid parity inside the coset: sum of floor(k_i / 2), odd or even.
    let even = |k: &IVec| k.iter().map(|x| x.div_euclid(2)).sum::<i64>().rem_euclid(2) == 0;
    let neighbours: Vec<Vec<usize>> = stencil
        .iter()
        .map(|k| {
            let mut out = Vec::new();
            for i in 0..s {
                for step in [2, -2] {
                    let mut n = k.clone();
                    n[i] += step;
                    if let Some(&j) = index.get(&n) {
                        out.push(j);
                    }
                }
            }
            out
        })
        .collect();
    let mut mate: Vec<Option<usize>> = vec![None; stencil.len()];
    fn augment(u: usize, nb: &[Vec<usize>], mate: &mut [Option<usize>], seen: &mut [bool]) -> bool {
        for &v in &nb[u] {
            if seen[v] {
                continue;
            }
            seen[v] = true;
            if mate[v].is_none_or(|w| augment(w, nb, mate, seen)) {
                mate[v] = Some(u);
                mate[u] = Some(v);
                return true;
            }
        }
        false
    }
    for u in 0..stencil.len() {
        if even(&stencil[u]) && mate[u].is_none() {
            let mut seen = vec![false; stencil.len()];
            augment(u, &neighbours, &mut mate, &mut seen);
        }
    }
    let mut pairs = Vec::new();
    let mut singles = Vec::new();
    for (u, m) in mate.iter().enumerate() {
        match m {
            Some(v) if even(&stencil[u]) => {
                // Lower point first along the pair's axis.
                let (a, b) = if stencil[u] < stencil[*v] { (u, *v) } else { (*v, u) };
                pairs.push((a, Some(b)));
            }
            Some(_) => {}
            None => singles.push((u, None)),
        }
    }
    pairs.sort();
    pairs.extend(singles);
    pairs
}

/// The body of `<f>_eval` with filtered fetches (`<f>_fetch_pair`).
pub(crate) fn emit_linear_body(d: &Derivation, plan: &Plan, lin: &LinearPlan, sh: &Shapes, name: &str) -> String {
    let mut body = Body::new();
    let frame = emit_frame(&mut body, sh, plan, name, &Fast);
    let ci = emit_candidate_choice(&mut body, sh, plan, &frame, &Fast);
    let nslots = lin.fetches(plan);
    // Per used reference: (sum, t) names per slot.
    let mut per_ref: BTreeMap<usize, Vec<(String, String)>> = BTreeMap::new();
    for r in plan.used_references() {
        let u = local_u(&mut body, sh, d, plan, r, &frame, &ci);
        let polys = &d.forms(r).polys;
        let exps = &polys[0].basis.exps;
        // Monomials that some weight uses, each one product from a smaller one.
        let used: Vec<usize> = (0..exps.len()).filter(|&e| polys.iter().any(|p| !p.coeffs[e].is_zero())).collect();
        let mut names: BTreeMap<Vec<u32>, String> = BTreeMap::new();
        names.insert(vec![0; sh.s], "1.0".into());
        let mut inputs = Vec::new();
        for &e in &used {
            inputs.push(monomial(&mut body, &mut names, &exps[e], &u));
        }
        let rows: Vec<Vec<Q>> = polys.iter().map(|p| used.iter().map(|&e| p.coeffs[e].clone()).collect()).collect();
        let w = crate::emit::cse::LinearMap::shared(&rows).emit(&mut body, &inputs, "wt");
        let slots: Vec<(String, String)> = lin.slots[r]
            .iter()
            .map(|&(a, b)| match b {
                Some(b) => {
                    let sum = body.bind("ws", &format!("{} + {}", w[a], w[b]));
                    let t = body.bind("t", &format!("clamp({} / max({sum}, 1e-30), 0.0, 1.0)", w[b]));
                    (sum, t)
                }
                None => (w[a].clone(), "0.0".into()),
            })
            .collect();
        per_ref.insert(r, slots);
    }
    // Per slot: positions and weights of the chosen candidate, one fetch.
    let mut terms = Vec::new();
    for slot in 0..nslots {
        let mut qa = Vec::new();
        let mut qb = Vec::new();
        let mut sums = Vec::new();
        let mut ts = Vec::new();
        for c in &plan.candidates {
            let r = c.reference;
            let offset = |k: usize| -> IVec {
                let p = plan.slots[r].iter().position(|x| *x == Some(k)).expect("every stencil index has a plan slot");
                c.offsets[p].clone()
            };
            match (lin.slots[r].get(slot), per_ref.get(&r).and_then(|v| v.get(slot))) {
                (Some(&(a, b)), Some((sum, t))) => {
                    let oa = offset(a);
                    qa.push(sh.ivec(&oa));
                    qb.push(sh.ivec(&b.map_or(oa, offset)));
                    sums.push(sum.clone());
                    ts.push(t.clone());
                }
                _ => {
                    qa.push(sh.ivec(&vec![0; sh.s]));
                    qb.push(sh.ivec(&vec![0; sh.s]));
                    sums.push("0.0".into());
                    ts.push("0.0".into());
                }
            }
        }
        let ja = position(&mut body, sh, plan, &frame, &ci, &qa);
        let jb = if qa == qb { ja.clone() } else { position(&mut body, sh, plan, &frame, &ci, &qb) };
        let sum = select_by_candidate(&mut body, &ci, &sums, "ws");
        let t = select_by_candidate(&mut body, &ci, &ts, "t");
        let f = body.bind("f", &format!("{name}_fetch_pair({ja}, {jb}, {t})"));
        terms.push(format!("{sum} * {f}"));
    }
    body.line(&format!("return {};", if terms.is_empty() { "0.0".into() } else { terms.join(" + ") }));
    body.text
}

/// Local coordinates of reference r (selected among its candidates).
fn local_u(body: &mut Body, sh: &Shapes, d: &Derivation, plan: &Plan, r: usize, frame: &Frame, ci: &str) -> String {
    let cands: Vec<usize> = (0..plan.candidates.len()).filter(|&i| plan.candidates[i].reference == r).collect();
    let mut acc = body.bind("u", &local_coords(sh, d, plan, &plan.candidates[cands[0]], &frame.w));
    for &i in &cands[1..] {
        let v = body.bind("u", &local_coords(sh, d, plan, &plan.candidates[i], &frame.w));
        acc = body.bind("u", &format!("select({acc}, {v}, {ci} == {i})"));
    }
    acc
}

/// base + M q for the chosen candidate's constant offset q.
fn position(body: &mut Body, sh: &Shapes, plan: &Plan, frame: &Frame, ci: &str, qs: &[String]) -> String {
    if plan.candidates.len() == 1 || qs.iter().all(|q| *q == qs[0]) {
        let q: IVec = parse_ivec(&qs[0]);
        return match super::locate::frame_times(sh, &frame.cols, &q) {
            Some(mq) => body.bind("j", &format!("{} + {mq}", frame.base)),
            None => frame.base.clone(),
        };
    }
    let q = select_by_candidate(body, ci, qs, "q");
    let parts: Vec<String> = (0..sh.s).map(|i| format!("{} * {q}.{}", frame.cols[i], AXES[i])).collect();
    body.bind("j", &format!("{} + {}", frame.base, parts.join(" + ")))
}

fn parse_ivec(s: &str) -> IVec {
    let inner = &s[s.find('(').map_or(0, |i| i + 1)..s.rfind(')').unwrap_or(s.len())];
    inner.split(',').map(|x| x.trim().parse().expect("ivec literals are written by Shapes::ivec")).collect()
}

/// The monomial u^e, built from a cached smaller one times one coordinate.
fn monomial(body: &mut Body, names: &mut BTreeMap<Vec<u32>, String>, e: &[u32], u: &str) -> String {
    if let Some(n) = names.get(e) {
        return n.clone();
    }
    let i = e.iter().position(|&x| x > 0).expect("the zero exponent is cached as 1.0");
    let mut smaller = e.to_vec();
    smaller[i] -= 1;
    let lower = monomial(body, names, &smaller, u);
    let name = if lower == "1.0" {
        format!("{u}.{}", AXES[i])
    } else {
        body.bind("mo", &format!("{lower} * {u}.{}", AXES[i]))
    };
    names.insert(e.to_vec(), name.clone());
    name
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::spec::catalog;

    fn derive(name: &str) -> Derivation {
        Derivation::new(&catalog::get(name).unwrap()).unwrap()
    }

    /// The pairing is a matching of axis neighbours two apart, and it is
    /// maximum for the filters (fetch counts from #8's targets are
    /// checks on the matching, not inputs to it).
    #[test]
    fn pairs_are_axis_neighbours_in_one_coset() {
        for name in ["bcc7", "bcc8", "fcc6", "bcc_linear", "cc_tricubic"] {
            let d = derive(name);
            let lin = LinearPlan::new(&d);
            for (r, slots) in lin.slots.iter().enumerate() {
                let st = &d.references[r].stencil;
                let mut seen = vec![false; st.len()];
                for &(a, b) in slots {
                    assert!(!std::mem::replace(&mut seen[a], true), "{name}: {a} twice");
                    if let Some(b) = b {
                        assert!(!std::mem::replace(&mut seen[b], true), "{name}: {b} twice");
                        let diff: IVec = st[b].iter().zip(&st[a]).map(|(x, y)| x - y).collect();
                        assert_eq!(diff.iter().map(|x| x.abs()).sum::<i64>(), 2, "{name}: {diff:?}");
                        assert_eq!(diff.iter().filter(|x| **x != 0).count(), 1, "{name}: {diff:?}");
                    }
                }
                assert!(seen.iter().all(|x| *x), "{name}: every sample fetched");
            }
        }
        let fetches = |n: &str| {
            let d = derive(n);
            LinearPlan::new(&d).fetches(&Plan::new(&d))
        };
        assert!(fetches("bcc7") <= 16, "{}", fetches("bcc7"));
        assert!(fetches("bcc8") <= 16, "{}", fetches("bcc8"));
        assert!(fetches("fcc6") <= 12, "{}", fetches("fcc6"));
    }

    /// The CPU mirror of the filtered eval reproduces the exact evaluator
    /// (float weights), and 8-bit weights stay close.
    #[test]
    fn filtered_eval_matches_the_exact_evaluator() {
        for name in ["bcc7", "fcc6", "bcc_linear", "courant"] {
            let d = derive(name);
            let plan = Plan::new(&d);
            let lin = LinearPlan::new(&d);
            let data = |j: &[i64]| (j.iter().fold(17i64, |h, &x| h.wrapping_mul(31).wrapping_add(x)) % 23) as f64;
            let mut seed = 99u64;
            let mut rnd = || {
                seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
                ((seed >> 33) as f64 / (1u64 << 31) as f64) * 12.0 - 6.0
            };
            for _ in 0..200 {
                let x: Vec<f64> = (0..d.facts.dim).map(|_| rnd()).collect();
                let exact = d.eval_f64(&x, &data).0;
                let v = lin.eval_f64(&d, &plan, &x, &data, None);
                assert!((v - exact).abs() < 1e-9 * (1.0 + exact.abs()), "{name} at {x:?}: {v} vs {exact}");
                let v8 = lin.eval_f64(&d, &plan, &x, &data, Some(8));
                assert!((v8 - exact).abs() < 0.1, "{name} 8-bit at {x:?}: {v8} vs {exact}");
            }
        }
    }

    /// Bernstein coefficients prove the weights of the simplicial catalog
    /// pieces non-negative; a negative one would show up here.
    #[test]
    fn weights_are_proven_non_negative() {
        let d = derive("bcc7");
        let p = LinearPlan::new(&d).proof;
        assert_eq!(p.weights, 30);
        assert_eq!(p.by_bernstein_coefficients, 30);
        // Box pieces: tensor-product Bernstein coefficients on the cube.
        for name in ["cc_tricubic", "cc_trilinear"] {
            let p = LinearPlan::new(&derive(name)).proof;
            assert_eq!(p.by_bernstein_coefficients, p.weights, "{name}");
        }
    }

    /// The tensor Bernstein test rejects a polynomial negative inside the box
    /// or with a negative coefficient, and accepts one non-negative there.
    #[test]
    fn tensor_bernstein_test_can_fail() {
        use crate::math::poly::Monomials;
        let basis = Monomials::get(2, 2);
        let poly = |f: &dyn Fn(u32, u32) -> Q| Poly {
            coeffs: basis.exps.iter().map(|e| f(e[0], e[1])).collect(),
            basis: basis.clone(),
        };
        let (zero, one) = ([Q::zero(), Q::zero()], [Q::one(), Q::one()]);
        // (x - 1/2)^2 >= 0, but its Bernstein coefficients on [0, 1] are 1/4, -1/4, 1/4.
        let sq = poly(&|a, b| match (a, b) {
            (2, 0) => Q::one(),
            (1, 0) => -Q::one(),
            (0, 0) => Q::frac(1, 4),
            _ => Q::zero(),
        });
        assert!(!tensor_bernstein_non_negative(&sq, &zero, &one));
        // x - 1: >= 0 on [1, 2] x [0, 1], negative on the unit box.
        let x1 = poly(&|a, b| match (a, b) {
            (1, 0) => Q::one(),
            (0, 0) => -Q::one(),
            _ => Q::zero(),
        });
        assert!(tensor_bernstein_non_negative(&x1, &[Q::one(), Q::zero()], &[Q::int(2), Q::one()]));
        assert!(!tensor_bernstein_non_negative(&x1, &zero, &one));
    }
}
