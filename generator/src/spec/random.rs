//! A fixed, seeded family of random specs: the derivation benchmark
//! (`boxforge bench --derive`) and the randomised oracle tests draw from it,
//! so "any direction matrix" is checked on matrices nobody chose by hand.
//!
//! The generator is a small xorshift (no dependency, same sequence on every
//! platform). A spec gets 3-9 directions in 3D (2-9 in 2D) with entries in
//! `[-range, range]`, rejected and redrawn until every direction is a non-zero
//! lattice vector and they span; nothing else is filtered, so specs that are
//! too large for the caps stay in the set (they must be refused quickly).

use crate::spec::lattice::Lattice;
use crate::spec::{Caps, Filter};

/// The lattices of the benchmark, 3D first.
pub const LATTICES: [&str; 5] = ["cc", "bcc", "fcc", "square", "quincunx"];

/// A deterministic xorshift64* stream.
#[derive(Clone, Debug)]
pub struct Rng(u64);

impl Rng {
    /// A stream from a seed (any value, 0 included).
    pub fn new(seed: u64) -> Rng {
        // Never zero; mixes small seeds.
        Rng(seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1)
    }

    /// The next value.
    pub fn next_u64(&mut self) -> u64 {
        let mut x = self.0;
        x ^= x >> 12;
        x ^= x << 25;
        x ^= x >> 27;
        self.0 = x;
        x.wrapping_mul(0x2545_F491_4F6C_DD1D)
    }

    /// Uniform in `lo..=hi`.
    pub fn range(&mut self, lo: i64, hi: i64) -> i64 {
        lo + (self.next_u64() % (hi - lo + 1) as u64) as i64
    }
}

/// One random spec: `count` directions on `lattice`, entries in `[-range, range]`.
///
/// # Panics
///
/// If `lattice` is not a built-in lattice name.
pub fn random_filter(rng: &mut Rng, name: &str, lattice: &str, count: usize, range: i64) -> Filter {
    let lattice = Lattice::builtin(lattice).expect("`lattice` is a built-in name (the precondition of random_filter)");
    let dim = lattice.dim();
    loop {
        let mut directions = Vec::with_capacity(count);
        while directions.len() < count {
            let v: Vec<i64> = (0..dim).map(|_| rng.range(-range, range)).collect();
            if v.iter().any(|&x| x != 0) && lattice.contains(&v) {
                directions.push(v);
            }
        }
        if let Ok(f) = Filter::new(name, "seeded random spec", lattice.clone(), directions, Caps::default()) {
            return f;
        }
    }
}

/// `count` specs from `seed`, cycling through [`LATTICES`] and the direction
/// counts 3..=9 (2..=9 in 2D), entries in [-2, 2].
pub fn benchmark_specs(seed: u64, count: usize) -> Vec<Filter> {
    let mut rng = Rng::new(seed);
    (0..count)
        .map(|i| {
            let lattice = LATTICES[i % LATTICES.len()];
            let min = if Lattice::builtin(lattice).expect("LATTICES holds built-in names").dim() == 2 { 2 } else { 3 };
            let n = min + (i / LATTICES.len()) % (10 - min);
            random_filter(&mut rng, &format!("random{i}"), lattice, n, 2)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_set_is_deterministic_and_covers_every_lattice_and_size() {
        let a = benchmark_specs(7, 40);
        let b = benchmark_specs(7, 40);
        assert_eq!(a, b);
        assert_ne!(a, benchmark_specs(8, 40));
        for l in LATTICES {
            assert!(a.iter().any(|f| f.lattice.name == l), "{l}");
        }
        let counts: std::collections::BTreeSet<usize> = a.iter().map(|f| f.directions.len()).collect();
        assert!(counts.contains(&3) && counts.contains(&9), "{counts:?}");
        for f in &a {
            assert!(f.directions.iter().flatten().all(|x| x.abs() <= 2));
        }
    }
}
