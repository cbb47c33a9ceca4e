use super::*;
use crate::derive::spline::SplineFacts;
use crate::derive::symmetry::point_group;
use crate::spec::{catalog, Caps};

/// A small deterministic generator of unit directions (xorshift).
fn unit_directions(dim: usize, count: usize, seed: u64) -> Vec<Vec<f64>> {
    let mut s = seed.max(1);
    let mut next = move || {
        s ^= s << 13;
        s ^= s >> 7;
        s ^= s << 17;
        (s >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
    };
    let mut out = Vec::new();
    while out.len() < count {
        let v: Vec<f64> = (0..dim).map(|_| next()).collect();
        let n = v.iter().map(|x| x * x).sum::<f64>().sqrt();
        if n > 0.2 && n <= 1.0 {
            out.push(v.iter().map(|x| x / n).collect());
        }
    }
    out
}

/// |Q(w) phihat(w) - 1| in f64, straight from the definitions (libm sin/cos).
fn residual(taps: &[(IVec, f64)], directions: &[IVec], w: &[f64]) -> f64 {
    let dot = |a: &IVec| a.iter().zip(w).map(|(x, y)| *x as f64 * y).sum::<f64>();
    let q: f64 = taps.iter().map(|(j, c)| c * dot(j).cos()).sum();
    let phi: f64 = directions
        .iter()
        .map(|xi| {
            let u = dot(xi) / 2.0;
            if u == 0.0 {
                1.0
            } else {
                u.sin() / u
            }
        })
        .product();
    (q * phi - 1.0).abs()
}

/// The smallest observed convergence order of the residual along random
/// directions, from h = 1e-1 and 5e-2; None when every residual is at the
/// f64 noise floor (then the residual is asserted tiny).
fn observed_order(taps: &[(IVec, f64)], directions: &[IVec], dim: usize) -> Option<f64> {
    let (h1, h2) = (1e-1, 5e-2);
    let mut worst: Option<f64> = None;
    for u in unit_directions(dim, 8, 0x9e37_79b9_7f4a_7c15) {
        let at = |h: f64| residual(taps, directions, &u.iter().map(|x| x * h).collect::<Vec<_>>());
        let (e1, e2) = (at(h1), at(h2));
        if e1 < 1e-12 && e2 < 1e-12 {
            continue;
        }
        let order = (e1 / e2).ln() / (h1 / h2).ln();
        worst = Some(worst.map_or(order, |w: f64| w.min(order)));
    }
    worst
}

fn f64_taps(p: &Prefilter) -> Vec<(IVec, f64)> {
    p.taps.iter().map(|(j, q)| (j.clone(), q.to_f64())).collect()
}

fn derive(f: &Filter) -> (Prefilter, usize, Vec<SignedPerm>) {
    let rho = SplineFacts::new(f).approximation_order;
    let group = point_group(f);
    (derive_prefilter(f, &group, rho).unwrap(), rho, group)
}

fn check_order(f: &Filter, p: &Prefilter, rho: usize) {
    if let Some(order) = observed_order(&f64_taps(p), &f.directions, f.dim()) {
        assert!(order >= rho as f64 - 0.3, "{}: observed order {order:.3} < rho = {rho}", f.name);
    }
    // Independently of the order estimate, the residual must be small.
    for u in unit_directions(f.dim(), 4, 7) {
        let w: Vec<f64> = u.iter().map(|x| x * 1e-2).collect();
        let e = residual(&f64_taps(p), &f.directions, &w);
        assert!(e < 10.0 * 1e-2f64.powi(rho as i32) + 1e-13, "{}: residual {e:e} at |w| = 1e-2", f.name);
    }
}

fn check_invariant(f: &Filter, p: &Prefilter, group: &[SignedPerm]) {
    let sum: Q = p.taps.iter().map(|(_, q)| q.clone()).sum();
    assert_eq!(sum, Q::one(), "{}: weights sum to {sum}", f.name);
    for (j, q) in &p.taps {
        assert!(f.lattice.contains(j), "{}: tap {j:?} off the lattice", f.name);
        for r in group {
            assert_eq!(&p.weight(&mat_vec_i(r, j)), q, "{}: q not invariant at {j:?}", f.name);
        }
        let neg: IVec = j.iter().map(|x| -x).collect();
        assert_eq!(&p.weight(&neg), q, "{}: q not even at {j:?}", f.name);
    }
    let keys: Vec<(i64, IVec)> = p.taps.iter().map(|(j, _)| (norm2(j), j.clone())).collect();
    let mut sorted = keys.clone();
    sorted.sort();
    sorted.dedup();
    assert_eq!(keys, sorted, "{}: taps not sorted or repeated", f.name);
}

#[test]
fn catalog_prefilters_reach_the_approximation_order() {
    let start = std::time::Instant::now();
    for f in catalog::all().unwrap() {
        let t = std::time::Instant::now();
        let (p, rho, group) = derive(&f);
        let dt = t.elapsed();
        println!(
            "{:16} rho={rho} |P|={:2} shells={} taps={:3} ({:.2?})",
            f.name,
            group.len(),
            p.shells,
            p.taps.len(),
            dt
        );
        check_order(&f, &p, rho);
        check_invariant(&f, &p, &group);
        if rho > 2 {
            // The test discriminates: without the prefilter the residual
            // is only O(|w|^2) (a filter of order rho > 2 has a non-zero
            // second-order Taylor term), so the estimate must see ~2.
            let delta = vec![(vec![0; f.dim()], 1.0)];
            let order = observed_order(&delta, &f.directions, f.dim()).unwrap();
            assert!(order < 2.3, "{}: the delta already has order {order:.3}", f.name);
        } else {
            assert_eq!(p.shells, 1, "{}", f.name);
            assert_eq!(p.taps, vec![(vec![0; f.dim()], Q::one())], "{}", f.name);
        }
    }
    println!("whole catalog: {:.2?}", start.elapsed());
}

#[test]
fn tricubic_needs_exactly_the_face_neighbours() {
    let f = catalog::get("cc_tricubic").unwrap();
    let (p, rho, group) = derive(&f);
    assert_eq!(rho, 4);
    check_order(&f, &p, rho);
    check_invariant(&f, &p, &group);
    assert_eq!(p.shells, 2);
    assert_eq!(p.taps.len(), 7);
    assert_eq!(p.taps[0].0, vec![0, 0, 0]);
    for (j, _) in &p.taps[1..] {
        assert_eq!(j.iter().map(|x| x.abs()).sum::<i64>(), 1, "{j:?} is not a face neighbour");
    }
    // One shell (a multiple of the delta) cannot cancel the order-2 term.
    assert!(matches!(derive_prefilter_with_limit(&f, &group, rho, 1), Err(Error::Prefilter { shells: 1 })));
    // The tensor structure: Q(w) must cancel prod_i (1 - w_i^2/6 + ...),
    // i.e. equal 1 + |w|^2/6 to second order; check along the axes in f64.
    let h = 1e-3;
    let along = p.symbol(&[h, 0.0, 0.0]);
    assert!(((along - 1.0) / (h * h) - 1.0 / 6.0).abs() < 1e-4, "{along}");
}

#[test]
fn two_dimensional_cases() {
    // zp: rho = 3, full square symmetry.
    let zp = catalog::get("zp").unwrap();
    let (p, rho, group) = derive(&zp);
    assert_eq!(rho, 3);
    check_order(&zp, &p, rho);
    check_invariant(&zp, &p, &group);
    assert_eq!(p.shells, 2);
    // A three-direction element with doubled directions: rho = 4 and a
    // group of order 4, so (1,0) and (1,1) lie in different shells and the
    // mixed term w1 w2 needs a diagonal shell as well.
    let l = Lattice::builtin("square").unwrap();
    let dirs = vec![vec![1, 0], vec![1, 0], vec![0, 1], vec![0, 1], vec![1, 1], vec![1, 1]];
    let f = Filter::new("courant2", "", l, dirs, Caps::default()).unwrap();
    let (p, rho, group) = derive(&f);
    assert_eq!((rho, group.len()), (4, 4));
    check_order(&f, &p, rho);
    check_invariant(&f, &p, &group);
    assert_eq!(p.shells, 3);
    assert!(derive_prefilter_with_limit(&f, &group, rho, 2).is_err());
    // Quincunx lattice: directions (1,1),(1,-1) three times each.
    let l = Lattice::builtin("quincunx").unwrap();
    let dirs = vec![vec![1, 1], vec![1, 1], vec![1, 1], vec![1, -1], vec![1, -1], vec![1, -1]];
    let f = Filter::new("qx", "", l, dirs, Caps::default()).unwrap();
    let (p, rho, group) = derive(&f);
    assert_eq!(rho, 3);
    check_order(&f, &p, rho);
    check_invariant(&f, &p, &group);
}

#[test]
fn low_orders_give_the_delta() {
    let f = catalog::get("bcc8").unwrap();
    let group = point_group(&f);
    for rho in [0, 1, 2] {
        let p = derive_prefilter(&f, &group, rho).unwrap();
        assert_eq!((p.shells, p.taps.clone()), (1, vec![(vec![0, 0, 0], Q::one())]));
    }
}

#[test]
fn shells_are_ordered_orbits() {
    let f = catalog::get("fcc6").unwrap();
    let group = point_group(&f);
    let sh = shells(&f.lattice, &group, 6);
    assert_eq!(sh[0], vec![vec![0, 0, 0]]);
    let mut seen = BTreeSet::new();
    for (k, s) in sh.iter().enumerate() {
        let n = norm2(&s[0]);
        assert!(s.iter().all(|j| norm2(j) == n && f.lattice.contains(j)));
        assert!(s.iter().all(|j| seen.insert(j.clone())), "shells overlap");
        if k > 0 {
            assert!(norm2(&sh[k - 1][0]) <= n);
        }
        // Closed under the group.
        for j in s {
            for r in &group {
                assert!(s.contains(&mat_vec_i(r, j)));
            }
        }
    }
    // Every fcc point of squared norm <= 4 appears (12 neighbours, 6 at distance 2).
    let count = sh.iter().filter(|s| norm2(&s[0]) <= 4).map(|s| s.len()).sum::<usize>();
    let brute = box_points(3, 2).iter().filter(|p| norm2(p) <= 4 && f.lattice.contains(p)).count();
    assert_eq!(count, brute);
}

#[test]
fn taylor_helpers_match_f64() {
    let dirs = vec![vec![1, 1, 1], vec![2, 0, 0], vec![-1, 1, 1]];
    let p = phihat_taylor(&dirs, 3, 6);
    let w: [f64; 3] = [0.03, -0.02, 0.045];
    let approx: f64 =
        p.iter().map(|(m, c)| c.to_f64() * m.iter().zip(&w).map(|(e, x)| x.powi(*e as i32)).product::<f64>()).sum();
    let exact: f64 = dirs
        .iter()
        .map(|xi| {
            let u = xi.iter().zip(&w).map(|(a, b)| *a as f64 * b).sum::<f64>() / 2.0;
            u.sin() / u
        })
        .product();
    assert!((approx - exact).abs() < 1e-14, "{approx} vs {exact}");
    let c = cos_taylor(&[2, -1, 1], 8);
    let approx: f64 =
        c.iter().map(|(m, c)| c.to_f64() * m.iter().zip(&w).map(|(e, x)| x.powi(*e as i32)).product::<f64>()).sum();
    let exact = (2.0 * w[0] - w[1] + w[2]).cos();
    assert!((approx - exact).abs() < 1e-13, "{approx} vs {exact}");
}
