//! Dimension 4: the lattices z4, d4, d4star and the derivation of 4D box
//! splines, checked exactly against the independent de Boor recurrence
//! (piece values) and by prefiltered polynomial reproduction. The
//! 8-direction splines on D4 and D4* are heavier and live in `#[ignore]`d
//! tests (`cargo test -p boxforge --test d4 -- --ignored`).

use boxforge::derive::Derivation;
use boxforge::eval::oracle::Oracle;
use boxforge::math::exact::Q;
use boxforge::math::linalg::{IVec, QVec};
use boxforge::spec::lattice::Lattice;
use boxforge::spec::{Caps, Filter};
use std::time::Instant;

struct Rng(u64);
impl Rng {
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        self.0
    }
    fn range(&mut self, lo: i64, hi: i64) -> i64 {
        lo + (self.next() % (hi - lo + 1) as u64) as i64
    }
}

fn data_at(seed: u64, j: &[i64]) -> i64 {
    let mut h = seed ^ 0x1234_5678;
    for &x in j {
        h = (h ^ (x as u64)).wrapping_mul(0x9E37_79B9_7F4A_7C15);
        h ^= h >> 29;
    }
    (h % 101) as i64 - 50
}

/// A point strictly inside a random cell, moved by a random lattice vector.
fn interior_point(d: &Derivation, rng: &mut Rng) -> QVec {
    let cells = &d.arrangement.cells;
    let cell = &cells[rng.range(0, cells.len() as i64 - 1) as usize];
    let verts = &cell.polytope.vertices;
    let weights: Vec<i64> = verts.iter().map(|_| rng.range(1, 97)).collect();
    let total: i64 = weights.iter().sum();
    let s = verts[0].len();
    let mut x: QVec = (0..s)
        .map(|i| verts.iter().zip(&weights).map(|(v, &w)| &v[i] * &Q::int(w)).sum::<Q>() / Q::int(total))
        .collect();
    for g in &d.filter.lattice.generators {
        let k = rng.range(-2, 2);
        for i in 0..s {
            x[i] = &x[i] + &Q::int(k * g[i]);
        }
    }
    x
}

fn filter(name: &str, lattice: &str, directions: Vec<IVec>) -> Filter {
    Filter::new(name, "", Lattice::builtin(lattice).unwrap(), directions, Caps::default()).unwrap()
}

fn axes(times: usize) -> Vec<IVec> {
    let mut out = Vec::new();
    for i in 0..4 {
        for _ in 0..times {
            let mut e = vec![0; 4];
            e[i] = 1;
            out.push(e);
        }
    }
    out
}

/// The 8 directions (±1,±1,±1,1).
fn eight() -> Vec<IVec> {
    let mut out = Vec::new();
    for a in [1, -1] {
        for b in [1, -1] {
            for c in [1, -1] {
                out.push(vec![a, b, c, 1]);
            }
        }
    }
    out
}

fn derive_timed(f: &Filter) -> (Derivation, f64) {
    let t = Instant::now();
    let d = Derivation::new(f).unwrap();
    d.derive_all_forms(&|_, _| {});
    let secs = t.elapsed().as_secs_f64();
    eprintln!(
        "{}: {} cells, {} reference pieces, group {}, stencil max {}, polynomials {}, prefilter {} taps, {secs:.2} s",
        f.name,
        d.arrangement.cells.len(),
        d.references.len(),
        d.group.len(),
        d.max_stencil(),
        d.polynomials(),
        d.prefilter.taps.len()
    );
    (d, secs)
}

fn check_against_oracle(d: &Derivation, points: usize) {
    let mut oracle = Oracle::new(&d.filter);
    let mut rng = Rng(0xB0C5 ^ d.filter.name.len() as u64);
    let data = |j: &[i64]| Q::int(data_at(7, j));
    for _ in 0..points {
        let x = interior_point(d, &mut rng);
        let ours = d.eval_exact(&x, &data);
        assert_eq!(ours, oracle.spline_value(&x, &data), "{} at {x:?}", d.filter.name);
        if let Some(bb) = d.eval_exact_bb(&x, &data) {
            assert_eq!(bb, ours, "{}: BB form", d.filter.name);
        }
    }
}

#[test]
fn explore() {
    for f in [
        filter("z4_linear", "z4", axes(2)),
        filter("z4_cubic", "z4", axes(4)),
        filter("d4star_eight", "d4star", eight()),
        filter("d4_eight", "d4", eight()),
    ] {
        let (d, _) = derive_timed(&f);
        check_against_oracle(&d, 50);
    }
}
