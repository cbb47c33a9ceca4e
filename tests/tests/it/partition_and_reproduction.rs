//! Partition of unity, and exact reproduction of every polynomial of degree
//! below the approximation order after prefiltering, for every catalog filter.

use boxforge::math::exact::Q;
use boxforge_tests::{all_catalog, eval_poly, prefiltered, random_interior_point, random_poly, Rng};

#[test]
fn partition_of_unity() {
    for d in all_catalog() {
        let mut rng = Rng(5);
        for _ in 0..boxforge_tests::points_for(&d, 100) {
            let x = random_interior_point(&d, &mut rng);
            assert_eq!(d.eval_exact(&x, &|_| Q::one()), Q::one(), "{}", d.filter.name);
            let (v, g) = d.eval_f64(&x.iter().map(|q| q.to_f64()).collect::<Vec<_>>(), &|_| 1.0);
            assert!((v - 1.0).abs() < 1e-9 && g.iter().all(|x| x.abs() < 1e-8), "{} f64 {v} {g:?}", d.filter.name);
        }
    }
}

#[test]
fn prefiltered_polynomials_of_degree_below_rho_are_reproduced() {
    for d in all_catalog() {
        let rho = d.facts.approximation_order;
        let mut rng = Rng(11);
        let p = random_poly(d.facts.dim, rho - 1, &mut rng);
        let data = prefiltered(&d, &p);
        for _ in 0..boxforge_tests::points_for(&d, 40) {
            let x = random_interior_point(&d, &mut rng);
            assert_eq!(d.eval_exact(&x, &data), eval_poly(&p, &x), "{} rho={rho}", d.filter.name);
        }
        // The order is sharp: without the prefilter a degree-(rho-1) monomial
        // generally is not reproduced when rho > 2 (sanity that the test can fail).
        if rho > 2 {
            let sq = |j: &[i64]| Q::int(j[0] * j[0]);
            let x = random_interior_point(&d, &mut rng);
            assert_ne!(d.eval_exact(&x, &sq), &x[0] * &x[0], "{}", d.filter.name);
        }
    }
}

#[test]
fn f64_evaluator_matches_exact_value_and_gradient() {
    for d in all_catalog() {
        let mut rng = Rng(21);
        let data_q = |j: &[i64]| Q::int(boxforge_tests::data_at(3, j));
        let data_f = |j: &[i64]| boxforge_tests::data_at(3, j) as f64;
        for _ in 0..boxforge_tests::points_for(&d, 30) {
            let x = random_interior_point(&d, &mut rng);
            let xf: Vec<f64> = x.iter().map(|q| q.to_f64()).collect();
            let exact = d.eval_exact(&x, &data_q).to_f64();
            let (v, g) = d.eval_f64(&xf, &data_f);
            assert!((v - exact).abs() < 1e-8, "{}: {v} vs {exact}", d.filter.name);
            // Gradient against an exact difference quotient (small rational step).
            let h = Q::frac(1, 1_000_000);
            for (i, gi) in g.iter().enumerate() {
                let mut xp = x.clone();
                xp[i] = &xp[i] + &h;
                let mut xm = x.clone();
                xm[i] = &xm[i] - &h;
                let fd = ((d.eval_exact(&xp, &data_q) - d.eval_exact(&xm, &data_q)) / (&h * &Q::int(2))).to_f64();
                assert!((gi - fd).abs() < 1e-3 * (1.0 + fd.abs()), "{} grad {i}: {gi} vs {fd}", d.filter.name);
            }
        }
    }
}
