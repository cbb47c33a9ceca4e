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
use rustc_hash::FxHashMap;
use std::collections::{BTreeMap, BinaryHeap};
use std::sync::{Mutex, OnceLock};

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
    ids: FxHashMap<Q, u32>,
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

/// Ratios w_b / w_a of interned weights: numbered by [`Interner`], each
/// pair of weight ids divided once.
struct Ratios {
    interner: Interner,
    of_weights: FxHashMap<(u32, u32), u32>,
    weight_values: Vec<Q>,
}

impl Ratios {
    /// Pair key of two terms (variable, weight id): (a, b, id of w_b / w_a), a < b.
    fn key_of(&mut self, x: (usize, u32), y: (usize, u32)) -> Key {
        let (lo, hi) = if x.0 < y.0 { (x, y) } else { (y, x) };
        let id = match self.of_weights.get(&(lo.1, hi.1)) {
            Some(&id) => id,
            None => {
                let id =
                    self.interner.id(self.weight_values[hi.1 as usize].clone() / &self.weight_values[lo.1 as usize]);
                self.of_weights.insert((lo.1, hi.1), id);
                id
            }
        };
        (lo.0, hi.0, id)
    }

    /// Is w_b / w_a the ratio numbered `q`? (Numbers no new ratio.)
    fn is(&self, wa: u32, wb: u32, q: u32) -> bool {
        match self.of_weights.get(&(wa, wb)) {
            Some(&id) => id == q,
            None => {
                self.weight_values[wb as usize].clone() / &self.weight_values[wa as usize]
                    == self.interner.values[q as usize]
            }
        }
    }
}

/// How many weights the memo of [`LinearMap::shared`] holds before it starts
/// over (a bound on its memory: a few tens of MB).
pub const MEMO_WEIGHTS: usize = 1 << 20;

/// Remembered results of [`LinearMap::shared`], by weight matrix.
#[derive(Default)]
struct Memo {
    maps: FxHashMap<Vec<Vec<Q>>, LinearMap>,
    weights: usize,
}

impl Memo {
    fn get(&self, weights: &[Vec<Q>]) -> Option<&LinearMap> {
        self.maps.get(weights)
    }

    fn insert(&mut self, weights: &[Vec<Q>], map: &LinearMap) {
        let size: usize = weights.iter().map(Vec::len).sum();
        if size > MEMO_WEIGHTS {
            return;
        }
        if self.weights + size > MEMO_WEIGHTS {
            self.maps.clear();
            self.weights = 0;
        }
        if self.maps.insert(weights.to_vec(), map.clone()).is_none() {
            self.weights += size;
        }
    }
}

fn memo() -> &'static Mutex<Memo> {
    static MEMO: OnceLock<Mutex<Memo>> = OnceLock::new();
    MEMO.get_or_init(Default::default)
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
    ///
    /// A pure function of `weights`, and the costliest step of emission:
    /// one module emits the same piece's map for its value, gradient and
    /// Hessian in several forms, and a process (the catalog's generation,
    /// a test binary) emits each filter in several layouts and variants. So
    /// the result is remembered per weight matrix, up to [`MEMO_WEIGHTS`].
    pub fn shared(weights: &[Vec<Q>]) -> LinearMap {
        if let Some(map) = memo().lock().unwrap_or_else(|e| e.into_inner()).get(weights) {
            return map.clone();
        }
        let map = LinearMap::shared_uncached(weights);
        let mut memo = memo().lock().unwrap_or_else(|e| e.into_inner());
        memo.insert(weights, &map);
        map
    }

    /// [`LinearMap::shared`] without the memo. Weights are interned, so that
    /// each ratio of two distinct weights is divided once; the choices (and
    /// so the generated code) are those of the plain greedy pass: ratios are
    /// numbered in order of first appearance and pairs ranked by (count,
    /// smallest key).
    fn shared_uncached(weights: &[Vec<Q>]) -> LinearMap {
        let mut map = LinearMap::dense(weights);
        let mut weight_ids: FxHashMap<Q, u32> = FxHashMap::default();
        let mut weight_values: Vec<Q> = Vec::new();
        let mut rows: Vec<BTreeMap<usize, u32>> = map
            .rows
            .iter()
            .map(|r| {
                r.iter()
                    .map(|(k, c)| {
                        let id = *weight_ids.entry(c.clone()).or_insert_with(|| {
                            weight_values.push(c.clone());
                            weight_values.len() as u32 - 1
                        });
                        (*k, id)
                    })
                    .collect()
            })
            .collect();
        let mut ratios = Ratios { interner: Interner::default(), of_weights: FxHashMap::default(), weight_values };
        let mut counts: FxHashMap<Key, i64> = FxHashMap::default();
        let mut rows_of: FxHashMap<Key, Vec<usize>> = FxHashMap::default();
        for (i, row) in rows.iter().enumerate() {
            let terms: Vec<(usize, u32)> = row.iter().map(|(k, c)| (*k, *c)).collect();
            for x in 0..terms.len() {
                for y in x + 1..terms.len() {
                    let k = ratios.key_of(terms[x], terms[y]);
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
            let q = ratios.interner.values[qid as usize].clone();
            let t = next_var;
            next_var += 1;
            map.defs.push((a, b, q.clone()));
            let mut touched: Vec<usize> = rows_of.remove(&key).unwrap_or_default();
            touched.sort_unstable();
            touched.dedup();
            for i in touched {
                let row = &rows[i];
                let (Some(&wa), Some(&wb)) = (row.get(&a), row.get(&b)) else { continue };
                if !ratios.is(wa, wb, qid) {
                    continue;
                }
                // Remove the pairs of a and b with everything else in the row.
                let others: Vec<(usize, u32)> =
                    row.iter().filter(|(k, _)| **k != a && **k != b).map(|(k, c)| (*k, *c)).collect();
                let mut dec = vec![ratios.key_of((a, wa), (b, wb))];
                for &(k, ck) in &others {
                    dec.push(ratios.key_of((a, wa), (k, ck)));
                    dec.push(ratios.key_of((b, wb), (k, ck)));
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
                for &(k, ck) in &others {
                    let nk = ratios.key_of((t, wa), (k, ck));
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
        let values = &ratios.weight_values;
        map.rows =
            rows.into_iter().map(|r| r.into_iter().map(|(k, w)| (k, values[w as usize].clone())).collect()).collect();
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
