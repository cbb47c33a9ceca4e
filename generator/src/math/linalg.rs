//! Small exact linear algebra on integer and rational vectors.
//! Matrices are row-major `Vec<Vec<_>>`; "columns" helpers take the vectors
//! that form the columns.

use crate::math::exact::Q;

/// An integer vector (or a matrix row).
pub type IVec = Vec<i64>;
/// An exact rational vector (or a matrix row).
pub type QVec = Vec<Q>;

/// The integer vector as rationals.
pub fn to_q(v: &[i64]) -> QVec {
    v.iter().map(|&x| Q::int(x)).collect()
}

/// a . b over the integers.
pub fn dot_i(a: &[i64], b: &[i64]) -> i64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

/// a . b of an integer and a rational vector.
pub fn dot_iq(a: &[i64], b: &[Q]) -> Q {
    let mut acc = Q::zero();
    for (x, y) in a.iter().zip(b) {
        if *x != 0 {
            acc += &(Q::int(*x) * y);
        }
    }
    acc
}

/// a . b over the rationals.
pub fn dot_q(a: &[Q], b: &[Q]) -> Q {
    let mut acc = Q::zero();
    for (x, y) in a.iter().zip(b) {
        if !x.is_zero() && !y.is_zero() {
            acc += &(x * y);
        }
    }
    acc
}

/// a + b.
pub fn add_q(a: &[Q], b: &[Q]) -> QVec {
    a.iter().zip(b).map(|(x, y)| x + y).collect()
}

/// a - b.
pub fn sub_q(a: &[Q], b: &[Q]) -> QVec {
    a.iter().zip(b).map(|(x, y)| x - y).collect()
}

/// a - b.
pub fn sub_i(a: &[i64], b: &[i64]) -> IVec {
    a.iter().zip(b).map(|(x, y)| x - y).collect()
}

/// a + b.
pub fn add_i(a: &[i64], b: &[i64]) -> IVec {
    a.iter().zip(b).map(|(x, y)| x + y).collect()
}

/// Matrix (rows) times vector.
pub fn mat_vec_q(m: &[QVec], v: &[Q]) -> QVec {
    m.iter().map(|row| dot_q(row, v)).collect()
}

/// Integer matrix (rows) times vector.
pub fn mat_vec_i(m: &[IVec], v: &[i64]) -> IVec {
    m.iter().map(|row| dot_i(row, v)).collect()
}

/// The transpose of a row-major matrix.
pub fn transpose<T: Clone>(m: &[Vec<T>]) -> Vec<Vec<T>> {
    if m.is_empty() {
        return vec![];
    }
    (0..m[0].len()).map(|j| m.iter().map(|r| r[j].clone()).collect()).collect()
}

/// The matrix whose columns are `cols` (as rows-major rational matrix).
pub fn from_columns_i(cols: &[&[i64]], dim: usize) -> Vec<QVec> {
    (0..dim).map(|i| cols.iter().map(|c| Q::int(c[i])).collect()).collect()
}

/// Row-reduces a copy of `m`; returns (reduced matrix, pivot columns, determinant factor).
fn row_reduce(m: &[QVec]) -> (Vec<QVec>, Vec<usize>, Q) {
    let mut a: Vec<QVec> = m.to_vec();
    let rows = a.len();
    let cols = if rows == 0 { 0 } else { a[0].len() };
    let mut pivots = Vec::new();
    let mut det = Q::one();
    let mut r = 0;
    for c in 0..cols {
        if r == rows {
            break;
        }
        let Some(p) = (r..rows).find(|&i| !a[i][c].is_zero()) else {
            continue;
        };
        if p != r {
            a.swap(p, r);
            det = -det;
        }
        let pv = a[r][c].clone();
        det *= &pv;
        let inv = pv.recip();
        for x in a[r].iter_mut() {
            *x = &*x * &inv;
        }
        for i in 0..rows {
            if i != r && !a[i][c].is_zero() {
                let f = a[i][c].clone();
                for j in 0..cols {
                    if !a[r][j].is_zero() {
                        let d = &f * &a[r][j];
                        a[i][j] -= &d;
                    }
                }
            }
        }
        pivots.push(c);
        r += 1;
    }
    (a, pivots, det)
}

/// Rank of a rational matrix (rows).
pub fn rank(m: &[QVec]) -> usize {
    row_reduce(m).1.len()
}

/// Rank of a set of integer vectors (as columns).
pub fn rank_of_vectors(vs: &[IVec]) -> usize {
    if vs.is_empty() {
        return 0;
    }
    let rows: Vec<QVec> = vs.iter().map(|v| to_q(v)).collect();
    rank(&rows)
}

/// Determinant of a square rational matrix (rows).
pub fn det(m: &[QVec]) -> Q {
    let n = m.len();
    let (_, pivots, d) = row_reduce(m);
    if pivots.len() < n {
        Q::zero()
    } else {
        d
    }
}

/// Determinant of the square matrix whose columns are the integer vectors;
/// None when it does not fit an i64 (it is always an integer).
pub fn det_columns(cols: &[&[i64]]) -> Option<i64> {
    let n = cols.len();
    let rows: Vec<QVec> = (0..n).map(|i| cols.iter().map(|c| Q::int(c[i])).collect()).collect();
    det(&rows).to_i64()
}

/// Inverse of a square rational matrix (rows); None if singular.
pub fn inverse(m: &[QVec]) -> Option<Vec<QVec>> {
    let n = m.len();
    let aug: Vec<QVec> = m
        .iter()
        .enumerate()
        .map(|(i, row)| {
            let mut r = row.clone();
            r.extend((0..n).map(|j| if i == j { Q::one() } else { Q::zero() }));
            r
        })
        .collect();
    let (red, pivots, _) = row_reduce(&aug);
    if pivots.len() < n || pivots[n - 1] >= n {
        return None;
    }
    Some(red.into_iter().map(|r| r[n..].to_vec()).collect())
}

/// Solves the square system m x = b.
pub fn solve(m: &[QVec], b: &[Q]) -> Option<QVec> {
    let inv = inverse(m)?;
    Some(mat_vec_q(&inv, b))
}

/// A basis of the null space of `m` (rows x cols), one vector per free column.
pub fn nullspace(m: &[QVec]) -> Vec<QVec> {
    if m.is_empty() {
        return vec![];
    }
    let cols = m[0].len();
    let (red, pivots, _) = row_reduce(m);
    let free: Vec<usize> = (0..cols).filter(|c| !pivots.contains(c)).collect();
    free.iter()
        .map(|&f| {
            let mut v = vec![Q::zero(); cols];
            v[f] = Q::one();
            for (r, &p) in pivots.iter().enumerate() {
                v[p] = -red[r][f].clone();
            }
            v
        })
        .collect()
}

/// Divides an integer vector by the gcd of its entries and makes its first
/// non-zero entry positive. Returns None for the zero vector.
pub fn primitive(v: &[i64]) -> Option<IVec> {
    let g = v.iter().fold(0i64, |g, &x| crate::math::exact::gcd(g, x));
    if g == 0 {
        return None;
    }
    let mut out: IVec = v.iter().map(|x| x / g).collect();
    if out.iter().find(|&&x| x != 0).copied().unwrap_or(0) < 0 {
        out.iter_mut().for_each(|x| *x = -*x);
    }
    Some(out)
}

/// Primitive integer normal of the hyperplane spanned by s-1 vectors in Z^s
/// (generalised cross product), sign-normalised. None if they are dependent.
///
/// # Panics
///
/// Unless `vs.len() + 1 == dim`, or if a minor does not fit an i64.
pub fn primitive_normal(vs: &[&[i64]], dim: usize) -> Option<IVec> {
    assert_eq!(vs.len() + 1, dim);
    let mut n = vec![0i64; dim];
    for (i, ni) in n.iter_mut().enumerate() {
        let minor: Vec<QVec> =
            (0..dim).filter(|&r| r != i).map(|r| vs.iter().map(|v| Q::int(v[r])).collect()).collect();
        let d = if minor.is_empty() { Q::one() } else { det(&minor) };
        let d = d.to_i64().expect(
            "a minor of integer vectors is an integer, and it fits an i64 for small entries (the precondition)",
        );
        *ni = if i % 2 == 0 { d } else { -d };
    }
    primitive(&n)
}

/// Scales a rational vector to a primitive integer vector (same direction,
/// first non-zero entry positive).
pub fn primitive_of_rational(v: &[Q]) -> Option<IVec> {
    let mut l: i64 = 1;
    for x in v {
        let (_, d) = x.numer_denom();
        let d: i64 = d.parse().ok()?;
        l = num_integer::lcm(l, d);
    }
    let iv: Option<IVec> = v.iter().map(|x| (x * &Q::int(l)).to_i64()).collect();
    primitive(&iv?)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn inverse_and_det() {
        let m = vec![to_q(&[2, 1]), to_q(&[1, 1])];
        assert_eq!(det(&m), Q::int(1));
        let inv = inverse(&m).unwrap();
        assert_eq!(inv, vec![to_q(&[1, -1]), to_q(&[-1, 2])]);
        let sing = vec![to_q(&[1, 2]), to_q(&[2, 4])];
        assert!(inverse(&sing).is_none());
        assert_eq!(det(&sing), Q::zero());
    }

    #[test]
    fn cross_product_normal() {
        let n = primitive_normal(&[&[1, 1, 1], &[-1, 1, 1]], 3).unwrap();
        assert_eq!(n, vec![0, 1, -1]);
        assert!(primitive_normal(&[&[1, 1, 1], &[2, 2, 2]], 3).is_none());
        assert_eq!(primitive_normal(&[&[1, 1]], 2).unwrap(), vec![1, -1]);
    }

    #[test]
    fn kernel() {
        let m = vec![to_q(&[1, 0, 1]), to_q(&[0, 1, 1])];
        let ns = nullspace(&m);
        assert_eq!(ns, vec![to_q(&[-1, -1, 1])]);
    }
}
