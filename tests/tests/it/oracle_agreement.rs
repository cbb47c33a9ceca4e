//! The evaluator (reference pieces + maps g, PP-form) agrees exactly with
//! an independent oracle (de Boor's recurrence) at random points strictly
//! inside cells, for every catalog filter.

use boxforge::eval::oracle::Oracle;
use boxforge::math::exact::Q;
use boxforge_tests::{all_catalog, data_at, random_interior_point, Rng};

const POINTS: usize = 200;

#[test]
fn evaluator_matches_de_boor_oracle_on_every_catalog_filter() {
    for d in all_catalog() {
        let mut oracle = Oracle::new(&d.filter);
        let mut rng = Rng(0xB0C5 ^ d.filter.name.len() as u64);
        let data = |j: &[i64]| Q::int(data_at(7, j));
        for _ in 0..boxforge_tests::points_for(&d, POINTS) {
            let x = random_interior_point(&d, &mut rng);
            let ours = d.eval_exact(&x, &data);
            let theirs = oracle.spline_value(&x, &data);
            assert_eq!(ours, theirs, "{} at {:?}", d.filter.name, x.iter().map(|q| q.to_string()).collect::<Vec<_>>());
            if let Some(bb) = d.eval_exact_bb(&x, &data) {
                assert_eq!(bb, ours, "{}: BB form disagrees with power form", d.filter.name);
            }
        }
    }
}

#[test]
fn single_basis_function_matches_oracle_across_the_support() {
    // phi itself (data = delta at the origin) at points spread over the support.
    for d in all_catalog() {
        let mut oracle = Oracle::new(&d.filter);
        let mut rng = Rng(99);
        let s = d.facts.dim;
        let delta = |j: &[i64]| {
            if j.iter().all(|&x| x == 0) {
                Q::one()
            } else {
                Q::zero()
            }
        };
        for _ in 0..boxforge_tests::points_for(&d, 50) {
            let x = random_interior_point(&d, &mut rng);
            assert_eq!(d.eval_exact(&x, &delta), oracle.phi(&x), "{} phi", d.filter.name);
            assert_eq!(d.pp.phi(&x), oracle.phi(&x), "{} PP-form phi", d.filter.name);
        }
        assert_eq!(s, d.filter.dim());
    }
}
