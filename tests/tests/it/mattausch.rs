//! Mattausch et al.'s sheared trilinear interpolation on BCC (seed 003,
//! "Comparison of Rendering Methods for BCC Grids", section 3.4) is the
//! catalog's `bcc_sheared_trilinear`, derived like any box spline from its
//! direction matrix. Here every view variant of it is checked against an
//! independent implementation of the paper's recipe (linear interpolation
//! along the four short edges of the sheared cell, then bilinear in the shear
//! plane), written from the paper and not from the box-spline machinery.

use boxforge::derive::Derivation;
use boxforge::spec::catalog;
use boxforge_tests::{data_at, Rng};

/// Data on the BCC lattice (integer points whose coordinates share one parity).
fn data(j: &[i64]) -> f64 {
    assert!(j.iter().all(|&x| (x - j[0]).rem_euclid(2) == 0), "{j:?} is not a BCC point");
    data_at(3, j) as f64
}

/// The paper's sheared trilinear interpolation at p: the shear planes are
/// the CC planes x_k = m (integer m; their BCC samples have every coordinate
/// of m's parity, a square grid of spacing 2), the cell's short edges run
/// along `shear` (shear[k] = 1) from plane m to plane m + 1, alpha is the
/// distance to the lower plane in units of the plane spacing.
fn sheared_trilinear(p: [f64; 3], k: usize, shear: [i64; 3]) -> f64 {
    assert_eq!(shear[k], 1);
    let m = p[k].floor();
    let alpha = p[k] - m;
    // Follow the short edge back to the lower plane.
    let q: Vec<f64> = (0..3).map(|a| p[a] - alpha * shear[a] as f64).collect();
    let (i, j) = match k {
        0 => (1, 2),
        1 => (0, 2),
        _ => (0, 1),
    };
    let corner = |x: f64| m + 2.0 * ((x - m) / 2.0).floor();
    let (ci, cj) = (corner(q[i]), corner(q[j]));
    let (u, v) = ((q[i] - ci) / 2.0, (q[j] - cj) / 2.0);
    // Value on the short edge from the plane-m sample at (ci + 2 di, cj + 2 dj).
    let edge = |di: i64, dj: i64| {
        let mut lo = [0i64; 3];
        lo[k] = m as i64;
        lo[i] = ci as i64 + 2 * di;
        lo[j] = cj as i64 + 2 * dj;
        let hi: Vec<i64> = (0..3).map(|a| lo[a] + shear[a]).collect();
        (1.0 - alpha) * data(&lo) + alpha * data(&hi)
    };
    let (a, b, c, d) = (edge(0, 0), edge(1, 0), edge(0, 1), edge(1, 1));
    (1.0 - v) * ((1.0 - u) * a + u * b) + v * ((1.0 - u) * c + u * d)
}

/// A view direction whose largest component is on axis k, with these signs.
fn view(k: usize, signs: [f64; 3]) -> [f64; 3] {
    let mut v = [0.35, 0.5, 0.6];
    v[k] = 0.9;
    [v[0] * signs[0], v[1] * signs[1], v[2] * signs[2]]
}

#[test]
fn every_view_variant_equals_the_papers_formula() {
    let f = catalog::get("bcc_sheared_trilinear").unwrap();
    assert!(f.view_dependent);
    let mut rng = Rng(2026);
    let range = 100.0; // data_at is in -50..=50
    let mut worst = 0.0f64;
    for k in 0..3 {
        // Shear directions s and -s are the same cell, so four sign patterns.
        for signs in [[1.0, 1.0, 1.0], [-1.0, 1.0, 1.0], [1.0, -1.0, 1.0], [-1.0, -1.0, 1.0]] {
            let w = view(k, signs);
            let (variant, label) = f.view_variant(w).unwrap();
            assert!(
                label.contains(["reference z along x", "reference z along y", "reference z along z"][k]),
                "{label}"
            );
            let d = Derivation::new(&variant).unwrap();
            // The paper: shear planes most perpendicular to the view, short
            // edges along the view's signs (normalised so shear[k] = 1).
            let shear = [0, 1, 2].map(|a| (signs[a] * signs[k]) as i64);
            for _ in 0..200 {
                let p = [0, 1, 2].map(|_| rng.range(-4000, 4000) as f64 / 997.0);
                let got = d.eval_f64(&p, &data).0;
                let want = sheared_trilinear(p, k, shear);
                worst = worst.max((got - want).abs() / range);
                assert!((got - want).abs() < 1e-6 * range, "{label}: at {p:?} derived {got}, paper {want}");
            }
        }
    }
    assert!(worst < 1e-6, "max |difference| {worst} of the range");
}

#[test]
fn the_wrong_shear_is_a_different_function() {
    // The check above can fail: the variant for one sign pattern differs
    // from the paper's formula with another shear direction.
    let f = catalog::get("bcc_sheared_trilinear").unwrap();
    let (variant, _) = f.view_variant(view(2, [1.0, 1.0, 1.0])).unwrap();
    let d = Derivation::new(&variant).unwrap();
    let mut rng = Rng(7);
    let differs = (0..50).any(|_| {
        let p = [0, 1, 2].map(|_| rng.range(-4000, 4000) as f64 / 997.0);
        (d.eval_f64(&p, &data).0 - sheared_trilinear(p, 2, [-1, 1, 1])).abs() > 1e-3
    });
    assert!(differs);
}

#[test]
fn view_variants_are_refused_for_bad_views_and_kept_for_other_filters() {
    let f = catalog::get("bcc_sheared_trilinear").unwrap();
    assert!(f.view_variant([0.0, 0.0, 0.0]).is_err());
    assert!(f.view_variant([f64::NAN, 1.0, 0.0]).is_err());
    let g = catalog::get("bcc7").unwrap();
    assert_eq!(g.view_variant([1.0, 0.0, 0.0]).unwrap().0, g);
}
