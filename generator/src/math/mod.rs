//! Exact mathematics shared by every stage: rationals with an i128 fast path
//! ([`exact`]), small dense linear algebra ([`linalg`]), multivariate
//! polynomials ([`poly`]) and convex polytopes ([`polytope`]).

pub mod exact;
pub mod linalg;
pub mod poly;
pub mod polytope;
pub mod scaled;

/// All k-subsets of 0..n, in lexicographic order.
pub fn subsets(n: usize, k: usize) -> Vec<Vec<usize>> {
    fn rec(start: usize, n: usize, k: usize, cur: &mut Vec<usize>, out: &mut Vec<Vec<usize>>) {
        if cur.len() == k {
            out.push(cur.clone());
            return;
        }
        for i in start..n {
            cur.push(i);
            rec(i + 1, n, k, cur, out);
            cur.pop();
        }
    }
    let mut out = Vec::new();
    rec(0, n, k, &mut Vec::new(), &mut out);
    out
}
