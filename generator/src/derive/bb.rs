//! Bernstein-Bezier form of simplicial pieces: every coefficient is an exact
//! linear combination of the stencil data, b_alpha = sum_k w_{alpha,k} c_k.

use crate::math::exact::{factorial, Q};
use crate::math::linalg::{solve, QVec};
use crate::math::poly::{Monomials, Poly};
use crate::math::scaled::{mul_add, ratio, Scaled};

/// The BB coefficients of a simplicial piece as weights of the stencil samples.
#[derive(Clone, Debug)]
pub struct BbForm {
    /// Polynomial degree of the piece (|alpha| of every multi-index).
    pub degree: usize,
    /// Simplex vertices v_0..v_s in local coordinates.
    pub vertices: Vec<QVec>,
    /// Multi-indices alpha (|alpha| = degree, s+1 entries).
    pub indices: Vec<Vec<u32>>,
    /// `weights[a][k]`: weight of stencil sample k in coefficient a.
    pub weights: Vec<Vec<Q>>,
}

impl BbForm {
    /// Converts the stencil polynomials (local coordinates) on the simplex.
    pub fn new(vertices: &[QVec], polys: &[Poly], degree: usize) -> BbForm {
        let s = vertices[0].len();
        let lam = Monomials::get(s + 1, degree);
        let indices: Vec<Vec<u32>> =
            lam.exps.iter().filter(|e| e.iter().sum::<u32>() as usize == degree).cloned().collect();
        let idx_pos: Vec<usize> =
            indices.iter().map(|e| lam.index_of(e).expect("`indices` are drawn from lam's own exponents")).collect();
        // u_j = sum_i lambda_i v_{i,j}; 1 = sum_i lambda_i.
        let forms: Vec<QVec> = (0..s).map(|j| vertices.iter().map(|v| v[j].clone()).collect()).collect();
        let ones: QVec = vec![Q::one(); s + 1];
        let zero = Q::zero();
        let src = Monomials::get(s, degree);
        // Homogenised image of every source monomial.
        let images: Vec<Poly> = src
            .exps
            .iter()
            .map(|beta| {
                let mut p = Poly::constant(s + 1, degree, Q::one());
                for (j, &k) in beta.iter().enumerate() {
                    for _ in 0..k {
                        p = p.mul_affine(&forms[j], &zero);
                    }
                }
                for _ in 0..(degree - beta.iter().sum::<u32>() as usize) {
                    p = p.mul_affine(&ones, &zero);
                }
                p
            })
            .collect();
        let dfact = factorial(degree as u32);
        let scale: Vec<Q> =
            indices.iter().map(|a| a.iter().fold(Q::one(), |acc, &k| acc * factorial(k)) / &dfact).collect();
        // weights[a][k] = sum_m conversion[a][m] * coefficient m of poly k.
        let conversion: Vec<Vec<Q>> = idx_pos
            .iter()
            .zip(&scale)
            .map(|(&pos, sc)| images.iter().map(|img| &img.coeffs[pos] * sc).collect())
            .collect();
        let weights = convert_integer(&conversion, polys).unwrap_or_else(|| convert_rational(&conversion, polys));
        BbForm { degree, vertices: vertices.to_vec(), indices, weights }
    }

    /// Barycentric coordinates of a local point.
    pub fn barycentric(&self, u: &[Q]) -> QVec {
        let s = u.len();
        // [v_1 - v_0 ... v_s - v_0] mu = u - v_0; lambda = (1 - sum mu, mu).
        let rows: Vec<QVec> =
            (0..s).map(|j| (1..=s).map(|i| &self.vertices[i][j] - &self.vertices[0][j]).collect()).collect();
        let rhs: QVec = (0..s).map(|j| &u[j] - &self.vertices[0][j]).collect();
        let mu = solve(&rows, &rhs)
            .expect("a simplex's vertices are affinely independent, so its edge matrix is invertible");
        let mut lam = vec![Q::one() - mu.iter().cloned().sum::<Q>()];
        lam.extend(mu);
        lam
    }

    /// The BB coefficients for given stencil data.
    pub fn coefficients(&self, data: &[Q]) -> QVec {
        self.weights
            .iter()
            .map(|w| w.iter().zip(data).filter(|(a, _)| !a.is_zero()).map(|(a, b)| a * b).sum())
            .collect()
    }

    /// sum_alpha b_alpha B_alpha(lambda), exactly.
    pub fn eval(&self, coeffs: &[Q], lambda: &[Q]) -> Q {
        let d = self.degree as u32;
        let df = factorial(d);
        self.indices
            .iter()
            .zip(coeffs)
            .map(|(a, b)| {
                let mut t = b * &df;
                for (l, &k) in lambda.iter().zip(a) {
                    t = t * l.pow(k) / factorial(k);
                }
                t
            })
            .sum()
    }
}

/// `conversion * coefficients` for every polynomial, in rationals.
fn convert_rational(conversion: &[Vec<Q>], polys: &[Poly]) -> Vec<Vec<Q>> {
    conversion
        .iter()
        .map(|row| {
            polys
                .iter()
                .map(|p| {
                    row.iter()
                        .zip(&p.coeffs)
                        .filter(|(a, b)| !a.is_zero() && !b.is_zero())
                        .fold(Q::zero(), |acc, (a, b)| acc + a * b)
                })
                .collect()
        })
        .collect()
}

/// The same product over common denominators in checked i128 (the inner
/// loop of every simplicial piece); `None` on overflow.
fn convert_integer(conversion: &[Vec<Q>], polys: &[Poly]) -> Option<Vec<Vec<Q>>> {
    let flat: Vec<Q> = conversion.iter().flatten().cloned().collect();
    let m = Scaled::from_q(&flat)?;
    let width = conversion.first().map_or(0, |r| r.len());
    let mut weights = vec![Vec::with_capacity(polys.len()); conversion.len()];
    for p in polys {
        let c = Scaled::from_q(&p.coeffs)?;
        let denominator = m.denominator.checked_mul(c.denominator)?;
        for (a, row) in m.numerators.chunks(width.max(1)).enumerate() {
            let mut acc: i128 = 0;
            for (x, y) in row.iter().zip(&c.numerators) {
                if *x != 0 && *y != 0 {
                    acc = mul_add(acc, *x, *y)?;
                }
            }
            weights[a].push(if acc == 0 { Q::zero() } else { ratio(acc, denominator) });
        }
    }
    Some(weights)
}
