//! Axis-aligned fetch order (docs/BOX_SPLINES.md §3.10): order the stencil so
//! consecutive offsets differ in as few coordinates as possible; each
//! non-zero coordinate of a difference is one vector add of a pre-scaled
//! column of the frame matrix.

use crate::math::linalg::IVec;

fn nnz(a: &[i64], b: &[i64]) -> usize {
    a.iter().zip(b).filter(|(x, y)| x != y).count()
}

fn l1(a: &[i64], b: &[i64]) -> i64 {
    a.iter().zip(b).map(|(x, y)| (x - y).abs()).sum()
}

/// Cost of stepping a -> b: (vector adds, L1 distance) lexicographically.
fn cost(a: &[i64], b: &[i64]) -> (usize, i64) {
    (nnz(a, b), l1(a, b))
}

/// A permutation of `points` (indices): greedy nearest neighbour from the
/// point nearest the origin, then 2-opt until no reversal improves.
pub fn axis_aligned_order(points: &[IVec]) -> Vec<usize> {
    let n = points.len();
    if n == 0 {
        return vec![];
    }
    let zero = vec![0; points[0].len()];
    let start = (0..n)
        .min_by_key(|&i| (cost(&zero, &points[i]), points[i].clone()))
        .expect("points is non-empty (checked above)");
    let mut order = vec![start];
    let mut used = vec![false; n];
    used[start] = true;
    for _ in 1..n {
        let last = &points[*order.last().expect("order starts with `start`")];
        let next = (0..n)
            .filter(|&i| !used[i])
            .min_by_key(|&i| (cost(last, &points[i]), i))
            .expect("fewer than n points are used before the last of n - 1 steps");
        used[next] = true;
        order.push(next);
    }
    // 2-opt on the open path (the first point stays first). The cost is
    // symmetric, so reversing order[i..=j] changes only the two edges at its
    // ends: each candidate is judged in O(1) from that difference.
    let edge = |a: usize, b: usize| cost(&points[a], &points[b]);
    let mut improved = true;
    let mut rounds = 0;
    while improved && rounds < 50 {
        improved = false;
        rounds += 1;
        for i in 1..n.saturating_sub(1) {
            for j in i + 1..n {
                let (before, after) = (edge(order[i - 1], order[i]), edge(order[i - 1], order[j]));
                let (mut d_adds, mut d_l1) = (after.0 as i64 - before.0 as i64, after.1 - before.1);
                if j + 1 < n {
                    let (old, new) = (edge(order[j], order[j + 1]), edge(order[i], order[j + 1]));
                    d_adds += new.0 as i64 - old.0 as i64;
                    d_l1 += new.1 - old.1;
                }
                if (d_adds, d_l1) < (0, 0) {
                    order[i..=j].reverse();
                    improved = true;
                }
            }
        }
    }
    order
}

/// Vector adds to walk `offsets` in order from the base (one per non-zero
/// coordinate of each difference, the first from the zero offset).
pub fn walk_adds(offsets: &[IVec]) -> usize {
    if offsets.is_empty() {
        return 0;
    }
    let zero = vec![0; offsets[0].len()];
    nnz(&zero, &offsets[0]) + offsets.windows(2).map(|w| nnz(&w[0], &w[1])).sum::<usize>()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn axis_aligned_walk_on_a_cube_beats_a_matvec() {
        // The 4x4x4 tricubic stencil: a snake order needs one add per step.
        let mut pts = Vec::new();
        for x in -1..3 {
            for y in -1..3 {
                for z in -1..3 {
                    pts.push(vec![x, y, z]);
                }
            }
        }
        let order = axis_aligned_order(&pts);
        let mut seen = order.clone();
        seen.sort();
        assert_eq!(seen, (0..64).collect::<Vec<_>>(), "a permutation");
        let walked: Vec<IVec> = order.iter().map(|&i| pts[i].clone()).collect();
        let adds = walk_adds(&walked);
        assert!(adds <= 64 + 2, "snake walk: {adds} adds");
        assert!(adds < 64 * 3);
    }
}
