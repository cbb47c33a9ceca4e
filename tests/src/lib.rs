//! Shared helpers for the cross-crate integration tests in `tests/tests/`:
//! a deterministic random source, random points strictly inside cells, and
//! pseudo-random lattice data.

use boxforge::derive::Derivation;
use boxforge::math::exact::Q;
use boxforge::math::linalg::{IVec, QVec};

/// SplitMix64: small, deterministic, good enough for test inputs.
pub struct Rng(pub u64);

impl Rng {
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    pub fn below(&mut self, n: u64) -> u64 {
        self.next_u64() % n
    }
    pub fn range(&mut self, lo: i64, hi: i64) -> i64 {
        lo + self.below((hi - lo + 1) as u64) as i64
    }
}

/// A random rational point strictly inside a random cell, moved to a random
/// cube of the same class (by a lattice vector within a few cubes).
pub fn random_interior_point(d: &Derivation, rng: &mut Rng) -> QVec {
    let cells = &d.arrangement.cells;
    let cell = &cells[rng.below(cells.len() as u64) as usize];
    let verts = &cell.polytope.vertices;
    // Strictly positive weights summing to 1: strictly inside (full-dimensional).
    let weights: Vec<i64> = verts.iter().map(|_| rng.range(1, 97)).collect();
    let total: i64 = weights.iter().sum();
    let s = verts[0].len();
    let mut x: QVec = (0..s)
        .map(|i| verts.iter().zip(&weights).map(|(v, &w)| &v[i] * &Q::int(w)).sum::<Q>() / Q::int(total))
        .collect();
    // Shift by a random lattice vector.
    let gens = &d.filter.lattice.generators;
    for g in gens {
        let k = rng.range(-2, 2);
        for i in 0..s {
            x[i] = &x[i] + &Q::int(k * g[i]);
        }
    }
    x
}

/// Deterministic integer data on lattice points in -50..=50.
pub fn data_at(seed: u64, j: &[i64]) -> i64 {
    let mut h = seed ^ 0x1234_5678;
    for &x in j {
        h = (h ^ (x as u64)).wrapping_mul(0x100_0000_01B3).rotate_left(17);
    }
    (Rng(h).next_u64() % 101) as i64 - 50
}

pub fn derive(name: &str) -> Derivation {
    let f = boxforge::spec::catalog::get(name).unwrap();
    Derivation::new(&f).unwrap()
}

pub fn all_catalog() -> Vec<Derivation> {
    boxforge::spec::catalog::names().into_iter().map(derive).collect()
}

pub fn ivec_to_q(v: &IVec) -> QVec {
    v.iter().map(|&x| Q::int(x)).collect()
}

/// A random polynomial of total degree <= deg in s variables: (exponents, coefficient).
pub fn random_poly(s: usize, deg: usize, rng: &mut Rng) -> Vec<(Vec<u32>, Q)> {
    let mut out = Vec::new();
    let mut e = vec![0u32; s];
    loop {
        if e.iter().sum::<u32>() as usize <= deg {
            out.push((e.clone(), Q::frac(rng.range(-9, 9), rng.range(1, 5))));
        }
        let mut k = 0;
        loop {
            if k == s {
                return out;
            }
            e[k] += 1;
            if e[k] as usize <= deg {
                break;
            }
            e[k] = 0;
            k += 1;
        }
    }
}

/// The value of a polynomial of [`random_poly`]'s shape at x.
pub fn eval_poly(p: &[(Vec<u32>, Q)], x: &[Q]) -> Q {
    p.iter().map(|(e, c)| e.iter().zip(x).fold(c.clone(), |acc, (&k, xi)| acc * xi.pow(k))).sum()
}

/// The samples of polynomial `p` after `d`'s quasi-interpolation
/// prefilter: sample j = sum over taps (k, w) of w p(j - k).
pub fn prefiltered<'a>(d: &'a Derivation, p: &'a [(Vec<u32>, Q)]) -> impl Fn(&[i64]) -> Q + 'a {
    move |j: &[i64]| -> Q {
        d.prefilter
            .taps
            .iter()
            .map(|(k, w)| {
                let pt: QVec = j.iter().zip(k).map(|(a, b)| Q::int(a - b)).collect();
                w * &eval_poly(p, &pt)
            })
            .sum()
    }
}

/// How many random points a catalog-wide exact check takes for `d`: `n`
/// up to 3D, a tenth (at least 3) in 4D, where one exact evaluation reads up
/// to 256 samples in rationals; the 4D filters get their full checks in d4.rs.
pub fn points_for(d: &Derivation, n: usize) -> usize {
    if d.facts.dim >= 4 {
        (n / 10).max(3)
    } else {
        n
    }
}
