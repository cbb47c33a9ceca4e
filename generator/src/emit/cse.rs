//! Shared subexpressions of a constant linear map (docs/EVALUATION_FORMS.md §3):
//! the coefficients of a piece are exact rational combinations of the
//! fetched samples, y_i = sum_k w_ik x_k, and neighbouring coefficients share
//! most of their sums and differences.
//!
//! A greedy pass (in the spirit of Paar's heuristic for constant
//! matrix-vector products) repeatedly names the pair `x_a + q x_b` that
//! occurs, with the same ratio q = w_b / w_a, in the most rows, and rewrites
//! those rows to use the new name. Rows are then written adding terms of
//! equal |weight| before one multiply. Everything is exact: the result is the
//! same linear map, which [`LinearMap::apply`] checks in the tests.

use super::writer::{lit, Body};
use crate::math::exact::Q;
use std::collections::{BTreeMap, BinaryHeap, HashMap};

/// A straight-line program for y = W x: `defs[m]` defines variable
/// `inputs + m` as `x_a + q x_b`; `rows[i]` is y_i as a sparse combination of
/// inputs and defined variables.
#[derive(Clone, Debug)]
pub struct LinearMap {
    /// Number of inputs x (variables 0..inputs).
    pub inputs: usize,
    /// (a, b, q): variable `inputs + m` is x_a + q x_b, for `defs[m]`.
    pub defs: Vec<(usize, usize, Q)>,
    /// Per output y_i: (variable, weight) pairs summed.
    pub rows: Vec<Vec<(usize, Q)>>,
}

type Key = (usize, usize, u32);

/// Numbers each distinct ratio once, in order of first appearance
/// (deterministic, so generated files are too).
#[derive(Default)]
struct Interner {
    ids: HashMap<Q, u32>,
    values: Vec<Q>,
}

impl Interner {
    fn id(&mut self, q: Q) -> u32 {
        if let Some(&id) = self.ids.get(&q) {
            return id;
        }
        let id = self.values.len() as u32;
        self.values.push(q.clone());
        self.ids.insert(q, id);
        id
    }
}

impl LinearMap {
    /// The dense map with no shared subexpressions: rows of weights over the inputs.
    pub fn dense(weights: &[Vec<Q>]) -> LinearMap {
        let inputs = weights.first().map(|w| w.len()).unwrap_or(0);
        let rows = weights
            .iter()
            .map(|w| w.iter().enumerate().filter(|(_, c)| !c.is_zero()).map(|(k, c)| (k, c.clone())).collect())
            .collect();
        LinearMap { inputs, defs: vec![], rows }
    }

    /// Greedy pair extraction until no pair occurs twice.
    pub fn shared(weights: &[Vec<Q>]) -> LinearMap {
        let mut map = LinearMap::dense(weights);
        let mut rows: Vec<BTreeMap<usize, Q>> = map.rows.iter().map(|r| r.iter().cloned().collect()).collect();
        let mut ratios = Interner::default();
        // Pair key of two terms (a < b): (a, b, id of w_b / w_a).
        let key_of = |ratios: &mut Interner, a: (usize, &Q), b: (usize, &Q)| -> Key {
            let (lo, hi) = if a.0 < b.0 { (a, b) } else { (b, a) };
            (lo.0, hi.0, ratios.id(hi.1.clone() / lo.1))
        };
        let mut counts: HashMap<Key, i64> = HashMap::new();
        let mut rows_of: HashMap<Key, Vec<usize>> = HashMap::new();
        for (i, row) in rows.iter().enumerate() {
            let terms: Vec<(usize, &Q)> = row.iter().map(|(k, c)| (*k, c)).collect();
            for x in 0..terms.len() {
                for y in x + 1..terms.len() {
                    let k = key_of(&mut ratios, terms[x], terms[y]);
                    *counts.entry(k).or_default() += 1;
                    rows_of.entry(k).or_default().push(i);
                }
            }
        }
        let mut heap: BinaryHeap<(i64, std::cmp::Reverse<Key>)> =
            counts.iter().filter(|(_, &c)| c >= 2).map(|(k, c)| (*c, std::cmp::Reverse(*k))).collect();
        let mut next_var = map.inputs;
        while let Some((c, std::cmp::Reverse(key))) = heap.pop() {
            if counts.get(&key).copied().unwrap_or(0) != c || c < 2 {
                continue; // stale entry
            }
            let (a, b, qid) = key;
            let q = ratios.values[qid as usize].clone();
            let t = next_var;
            next_var += 1;
            map.defs.push((a, b, q.clone()));
            let mut touched: Vec<usize> = rows_of.remove(&key).unwrap_or_default();
            touched.sort_unstable();
            touched.dedup();
            for i in touched {
                let row = &rows[i];
                let (Some(wa), Some(wb)) = (row.get(&a), row.get(&b)) else { continue };
                if wb.clone() / wa != q {
                    continue;
                }
                let wa = wa.clone();
                // Remove the pairs of a and b with everything else in the row.
                let others: Vec<(usize, Q)> =
                    row.iter().filter(|(k, _)| **k != a && **k != b).map(|(k, c)| (*k, c.clone())).collect();
                let wb = row[&b].clone();
                let mut dec = vec![key_of(&mut ratios, (a, &wa), (b, &wb))];
                for (k, ck) in &others {
                    dec.push(key_of(&mut ratios, (a, &wa), (*k, ck)));
                    dec.push(key_of(&mut ratios, (b, &wb), (*k, ck)));
                }
                for k in dec {
                    if let Some(n) = counts.get_mut(&k) {
                        *n -= 1;
                        if *n >= 2 {
                            heap.push((*n, std::cmp::Reverse(k)));
                        }
                    }
                }
                let row = &mut rows[i];
                row.remove(&a);
                row.remove(&b);
                for (k, ck) in &others {
                    let nk = key_of(&mut ratios, (t, &wa), (*k, ck));
                    let n = counts.entry(nk).or_default();
                    *n += 1;
                    rows_of.entry(nk).or_default().push(i);
                    if *n >= 2 {
                        heap.push((*n, std::cmp::Reverse(nk)));
                    }
                }
                row.insert(t, wa);
            }
        }
        map.rows = rows.into_iter().map(|r| r.into_iter().collect()).collect();
        map
    }

    /// Applies the program exactly (tests, and a check that it is the map).
    pub fn apply(&self, x: &[Q]) -> Vec<Q> {
        let mut vars: Vec<Q> = x.to_vec();
        for (a, b, q) in &self.defs {
            let v = vars[*a].clone() + q.clone() * &vars[*b];
            vars.push(v);
        }
        self.rows.iter().map(|r| r.iter().map(|(k, c)| c.clone() * &vars[*k]).sum()).collect()
    }

    /// Static op count of `LinearMap::emit` (adds, subtracts, multiplies).
    pub fn ops(&self) -> usize {
        let defs: usize = self.defs.iter().map(|(_, _, q)| 1 + usize::from(!q.abs().is_one())).sum();
        let rows: usize = self.rows.iter().map(|r| row_ops(r)).sum();
        defs + rows
    }

    /// Writes the program; `inputs` names the input variables. Returns the
    /// names of the rows ("0.0" for an empty row).
    pub(crate) fn emit(&self, body: &mut Body, inputs: &[String], prefix: &str) -> Vec<String> {
        let mut names: Vec<String> = inputs.to_vec();
        // A definition is only written if some row or later definition uses it.
        let mut used = vec![false; self.inputs + self.defs.len()];
        for r in &self.rows {
            for (k, _) in r {
                used[*k] = true;
            }
        }
        for (m, (a, b, _)) in self.defs.iter().enumerate().rev() {
            if used[self.inputs + m] {
                used[*a] = true;
                used[*b] = true;
            }
        }
        for (m, (a, b, q)) in self.defs.iter().enumerate() {
            if !used[self.inputs + m] {
                names.push(String::new());
                continue;
            }
            let expr = if q.is_one() {
                format!("{} + {}", names[*a], names[*b])
            } else if q.is_negative() && q.abs().is_one() {
                format!("{} - {}", names[*a], names[*b])
            } else if q.is_negative() {
                format!("{} - {} * {}", names[*a], lit(&q.abs()), names[*b])
            } else {
                format!("{} + {} * {}", names[*a], lit(q), names[*b])
            };
            let n = body.bind("s", &expr);
            names.push(n);
        }
        self.rows
            .iter()
            .map(|r| {
                let e = row_expr(r, &names);
                if e == "0.0" || (r.len() == 1 && r[0].1.is_one()) {
                    e
                } else {
                    body.bind(prefix, &e)
                }
            })
            .collect()
    }
}

fn row_ops(r: &[(usize, Q)]) -> usize {
    if r.is_empty() {
        return 0;
    }
    let mut classes: Vec<Q> = r.iter().map(|(_, c)| c.abs()).collect();
    classes.sort();
    classes.dedup();
    r.len() - 1 + classes.iter().filter(|c| !c.is_one()).count()
}

/// sum_classes |w| * (sum of +-x), the unit class first and unscaled.
fn row_expr(r: &[(usize, Q)], names: &[String]) -> String {
    if r.is_empty() {
        return "0.0".into();
    }
    let mut classes: BTreeMap<Q, Vec<(bool, &str)>> = BTreeMap::new();
    for (k, c) in r {
        classes.entry(c.abs()).or_default().push((c.is_negative(), names[*k].as_str()));
    }
    let mut out = String::new();
    let push = |neg: bool, piece: &str, out: &mut String| {
        if out.is_empty() {
            if neg {
                out.push('-');
            }
            out.push_str(piece);
        } else {
            out.push_str(if neg { " - " } else { " + " });
            out.push_str(piece);
        }
    };
    let one = Q::one();
    if let Some(terms) = classes.get(&one) {
        for (neg, n) in terms {
            push(*neg, n, &mut out);
        }
    }
    for (mag, terms) in &classes {
        if mag.is_one() {
            continue;
        }
        // Factor the sign of the first term out of the group.
        let lead_neg = terms[0].0;
        let inner: String = if terms.len() == 1 {
            terms[0].1.to_string()
        } else {
            let mut s = String::new();
            for (i, (neg, n)) in terms.iter().enumerate() {
                if i == 0 {
                    s.push_str(n);
                } else {
                    s.push_str(if *neg != lead_neg { " - " } else { " + " });
                    s.push_str(n);
                }
            }
            format!("({s})")
        };
        push(lead_neg, &format!("{} * {inner}", lit(mag)), &mut out);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn q(n: i64, d: i64) -> Q {
        Q::frac(n, d)
    }

    #[test]
    fn shared_program_is_the_same_map_and_cheaper() {
        // Rows sharing x0 + x1 and x2 - x3 (scaled).
        let w = vec![
            vec![q(1, 1), q(1, 1), q(1, 2), q(-1, 2), q(0, 1)],
            vec![q(3, 1), q(3, 1), q(1, 1), q(-1, 1), q(1, 1)],
            vec![q(-2, 1), q(-2, 1), q(0, 1), q(0, 1), q(5, 3)],
            vec![q(0, 1), q(0, 1), q(7, 1), q(-7, 1), q(1, 1)],
        ];
        let dense = LinearMap::dense(&w);
        let shared = LinearMap::shared(&w);
        let x: Vec<Q> = (0..5).map(|i| q(i * i + 3, i + 2)).collect();
        assert_eq!(dense.apply(&x), shared.apply(&x));
        assert!(shared.ops() < dense.ops(), "{} vs {}", shared.ops(), dense.ops());
        assert!(!shared.defs.is_empty());
    }

    #[test]
    fn random_maps_are_preserved() {
        let mut seed = 12345u64;
        let mut next = || {
            seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            ((seed >> 33) % 7) as i64 - 3
        };
        for _ in 0..20 {
            let w: Vec<Vec<Q>> = (0..9).map(|_| (0..8).map(|_| q(next(), 1 + next().abs())).collect()).collect();
            let m = LinearMap::shared(&w);
            let x: Vec<Q> = (0..8).map(|i| q(2 * i - 5, 3)).collect();
            assert_eq!(LinearMap::dense(&w).apply(&x), m.apply(&x));
            assert!(m.ops() <= LinearMap::dense(&w).ops());
        }
    }

    #[test]
    fn emitted_rows_count_what_ops_says() {
        let w = vec![vec![q(1, 1), q(-1, 1), q(1, 2)], vec![q(2, 1), q(-2, 1), q(0, 1)]];
        let m = LinearMap::shared(&w);
        let mut body = Body::new();
        let names = m.emit(&mut body, &["a".into(), "b".into(), "c".into()], "b");
        assert_eq!(names.len(), 2);
        assert_eq!(super::super::writer::count_ops(&body.text), m.ops());
    }
}
