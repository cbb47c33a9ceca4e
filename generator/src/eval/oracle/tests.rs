use super::*;
use crate::spec::{catalog, Caps};
use std::time::Instant;

/// Deterministic LCG (Knuth's MMIX constants).
struct Lcg(u64);
impl Lcg {
    fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        self.0 >> 33
    }
    /// Uniform integer in [lo, hi].
    fn range(&mut self, lo: i64, hi: i64) -> i64 {
        lo + (self.next() % ((hi - lo + 1) as u64)) as i64
    }
}

const DEN: i64 = 97;

/// Knot-plane normals of a filter (every (s-1)-subset of columns),
/// computed independently of the oracle's own list.
fn knot_normals(f: &Filter) -> Vec<IVec> {
    fn rec(f: &Filter, start: usize, cur: &mut Vec<usize>, out: &mut Vec<IVec>) {
        let s = f.dim();
        if cur.len() == s - 1 {
            let vs: Vec<&[i64]> = cur.iter().map(|&k| f.directions[k].as_slice()).collect();
            if let Some(n) = primitive_normal(&vs, s) {
                if !out.contains(&n) {
                    out.push(n);
                }
            }
            return;
        }
        for i in start..f.directions.len() {
            cur.push(i);
            rec(f, i + 1, cur, out);
            cur.pop();
        }
    }
    let mut out = Vec::new();
    rec(f, 0, &mut Vec::new(), &mut out);
    out
}

/// A random point with coordinates k/97 in (-r, r), redrawn until it is off
/// every (centred or not) knot plane: 2 n.x not an integer, i.e. 97 does
/// not divide n.k, for every knot normal n, and off the axis planes.
fn generic_point(rng: &mut Lcg, f: &Filter, r: i64) -> QVec {
    let normals = knot_normals(f);
    loop {
        let k: IVec = (0..f.dim()).map(|_| rng.range(-r * DEN + 1, r * DEN - 1)).collect();
        let on_plane =
            normals.iter().any(|n| crate::math::linalg::dot_i(n, &k) % DEN == 0) || k.iter().any(|&x| x % DEN == 0);
        if !on_plane {
            return k.iter().map(|&x| Q::frac(x, DEN)).collect();
        }
    }
}

fn q(n: i64, d: i64) -> Q {
    Q::frac(n, d)
}

fn custom(lattice: &str, dirs: &[&[i64]]) -> Filter {
    Filter::new(
        "test",
        "",
        Lattice::builtin(lattice).unwrap(),
        dirs.iter().map(|d| d.to_vec()).collect(),
        Caps::default(),
    )
    .unwrap()
}

/// Centred linear B-spline (hat).
fn hat(t: &Q) -> Q {
    let v = Q::one() - t.abs();
    if v.is_negative() {
        Q::zero()
    } else {
        v
    }
}

/// Centred quadratic B-spline.
fn b2(t: &Q) -> Q {
    let a = t.abs();
    if a < q(1, 2) {
        q(3, 4) - &a * &a
    } else if a < q(3, 2) {
        let u = q(3, 2) - a;
        &u * &u / Q::int(2)
    } else {
        Q::zero()
    }
}

/// Centred cubic B-spline.
fn b3(t: &Q) -> Q {
    let a = t.abs();
    if a < Q::one() {
        q(2, 3) - &a * &a + &a * &a * &a / Q::int(2)
    } else if a < Q::int(2) {
        let u = Q::int(2) - a;
        &u * &u * &u / Q::int(6)
    } else {
        Q::zero()
    }
}

/// Half the widest extent of the support's bounding box, rounded up.
fn radius(f: &Filter) -> i64 {
    (0..f.dim())
        .map(|i| f.directions.iter().map(|d| d[i].abs()).sum::<i64>())
        .max()
        .unwrap()
        .saturating_add(1)
        .div_euclid(2)
}

fn pts(n: usize, seed: u64, f: &Filter, r: i64) -> Vec<QVec> {
    let mut rng = Lcg(seed);
    (0..n).map(|_| generic_point(&mut rng, f, r)).collect()
}

#[test]
fn oracle_tensor_products_match_closed_forms() {
    // square, e1,e1,e2,e2: hat(x) hat(y)
    let f = custom("square", &[&[1, 0], &[1, 0], &[0, 1], &[0, 1]]);
    let mut o = Oracle::new(&f);
    for x in pts(12, 1, &f, 2) {
        assert_eq!(o.phi(&x), hat(&x[0]) * hat(&x[1]), "bilinear at {x:?}");
    }
    // square, flipped columns give the same centred element.
    let g = custom("square", &[&[1, 0], &[-1, 0], &[0, 1], &[0, -1]]);
    let mut og = Oracle::new(&g);
    for x in pts(12, 2, &g, 2) {
        assert_eq!(og.phi(&x), hat(&x[0]) * hat(&x[1]), "flipped bilinear at {x:?}");
    }
    type Profile = fn(&Q) -> Q;
    let closed: [(&str, Profile); 3] = [("cc_trilinear", hat), ("cc_triquadratic", b2), ("cc_tricubic", b3)];
    for (name, b) in closed {
        let f = catalog::get(name).unwrap();
        let mut o = Oracle::new(&f);
        let mut nonzero = 0;
        for x in pts(10, 3, &f, radius(&f)) {
            let want = b(&x[0]) * b(&x[1]) * b(&x[2]);
            nonzero += !want.is_zero() as usize;
            assert_eq!(o.phi(&x), want, "{name} at {x:?}");
        }
        assert!(nonzero >= 3, "{name}: too few points inside the support");
    }
    // bcc12 = tricubic on 2Z^3, normalised for det G = 4: (1/2) prod b3(x_i/2).
    let f = catalog::get("bcc12").unwrap();
    let mut o = Oracle::new(&f);
    for x in pts(10, 4, &f, 4) {
        let want = q(1, 2) * b3(&(&x[0] / &Q::int(2))) * b3(&(&x[1] / &Q::int(2))) * b3(&(&x[2] / &Q::int(2)));
        assert_eq!(o.phi(&x), want, "bcc12 at {x:?}");
    }
}

/// The Courant hat, by barycentric coordinates on the six triangles
/// around the origin of the three-direction mesh: in triangle (0, v1, v2)
/// with x = a v1 + b v2 (Cramer), phi = 1 - a - b.
fn courant_hat(x: &[Q]) -> Q {
    let ring: [(i64, i64); 6] = [(1, 0), (1, 1), (0, 1), (-1, 0), (-1, -1), (0, -1)];
    for i in 0..6 {
        let (p, r) = (ring[i], ring[(i + 1) % 6]);
        let det = Q::int(p.0 * r.1 - p.1 * r.0);
        let a = (&x[0] * &Q::int(r.1) - &x[1] * &Q::int(r.0)) / &det;
        let b = (&x[1] * &Q::int(p.0) - &x[0] * &Q::int(p.1)) / &det;
        if !a.is_negative() && !b.is_negative() && &a + &b <= Q::one() {
            return Q::one() - a - b;
        }
    }
    Q::zero()
}

#[test]
fn oracle_courant_is_the_barycentric_hat() {
    let f = catalog::get("courant").unwrap();
    let mut o = Oracle::new(&f);
    // Hand-picked points: near the centre, in each of the six triangles.
    let hand: Vec<(QVec, Q)> = vec![
        (vec![q(1, 97), q(2, 97)], q(95, 97)), // 0 < x < y: 1 - y
        (vec![q(2, 97), q(1, 97)], q(95, 97)), // 0 < y < x: 1 - x
        (vec![q(1, 2), q(1, 5)], q(1, 2)),     // 1 - x
        (vec![q(1, 5), q(1, 2)], q(1, 2)),     // 1 - y
        (vec![q(-1, 3), q(1, 4)], q(5, 12)),   // 1 - (y - x)
        (vec![q(1, 4), q(-1, 3)], q(5, 12)),   // 1 - (x - y)
        (vec![q(-1, 2), q(-1, 5)], q(1, 2)),   // 1 + x
        (vec![q(-2, 7), q(-3, 5)], q(2, 5)),   // 1 + y
        (vec![q(4, 5), q(-1, 4)], Q::zero()),  // outside the hexagon
        (vec![q(3, 2), q(1, 3)], Q::zero()),
    ];
    for (x, want) in &hand {
        assert_eq!(courant_hat(x), *want, "hand formula at {x:?}");
        assert_eq!(o.phi(x), *want, "oracle at {x:?}");
    }
    let mut inside = 0;
    for x in pts(40, 5, &f, radius(&f)) {
        let want = courant_hat(&x);
        inside += !want.is_zero() as usize;
        assert_eq!(o.phi(&x), want, "courant at {x:?}");
    }
    assert!(inside >= 5, "only {inside} of 40 points inside");
    // Non-centred: M is supported on the hexagon around c = (1,1), max 1.
    assert_eq!(o.box_spline(&[q(100, 97), q(99, 97)]), q(94, 97)); // phi(3/97, 2/97) = 1 - 3/97
    assert_eq!(o.box_spline(&[q(-1, 97), q(1, 2)]), Q::zero());
    // Flipping a column shifts M: M_{Xi with -xi}(x) = M_Xi(x + xi).
    let g = custom("square", &[&[1, 0], &[0, 1], &[-1, -1]]);
    let mut og = Oracle::new(&g);
    for x in pts(20, 6, &f, 2) {
        let shifted = vec![&x[0] + &Q::one(), &x[1] + &Q::one()];
        assert_eq!(og.box_spline(&x), o.box_spline(&shifted), "flip at {x:?}");
        assert_eq!(og.phi(&x), courant_hat(&x));
    }
}

#[test]
fn oracle_partition_of_unity_and_linear_reproduction_for_the_catalog() {
    for f in catalog::all().unwrap() {
        let mut o = Oracle::new(&f);
        for (i, x) in pts(3, 7, &f, radius(&f)).into_iter().enumerate() {
            let w = o.weights(&x);
            let total: Q = w.iter().map(|(_, v)| v.clone()).sum();
            assert_eq!(total, Q::one(), "{}: partition of unity at {x:?}", f.name);
            assert_eq!(o.spline_value(&x, &|_| Q::one()), Q::one());
            // Every centred element here is symmetric with rho >= 2, so it
            // reproduces linear polynomials: sum_j j phi(x - j) = x.
            for k in 0..f.dim() {
                let v = o.spline_value(&x, &|j: &[i64]| Q::int(j[k]));
                assert_eq!(v, x[k], "{}: linear reproduction, coordinate {k}, point {i}", f.name);
            }
            assert!(w.iter().all(|(j, _)| f.lattice.contains(j)));
        }
    }
}

#[test]
fn oracle_phi_is_symmetric() {
    for f in catalog::all().unwrap() {
        let mut o = Oracle::new(&f);
        let mut nonzero = 0;
        // The support fills less of its bounding box in 4D: more points.
        let n = if f.dim() == 4 { 40 } else { 6 };
        for x in pts(n, 11, &f, radius(&f)) {
            let neg: QVec = x.iter().map(|v| -v).collect();
            let a = o.phi(&x);
            nonzero += !a.is_zero() as usize;
            assert_eq!(a, o.phi(&neg), "{}: phi(x) != phi(-x) at {x:?}", f.name);
            assert!(!a.is_negative());
        }
        assert!(nonzero >= 1, "{}: no point inside the support", f.name);
    }
}

#[test]
fn oracle_memo_is_consistent_across_points() {
    // Interleaving points (memo resets) must agree with fresh oracles.
    let f = catalog::get("bcc7").unwrap();
    let ps = pts(5, 13, &f, 2);
    let mut shared = Oracle::new(&f);
    let first: Vec<Q> = ps.iter().map(|x| shared.phi(x)).collect();
    for (x, v) in ps.iter().zip(&first).rev() {
        assert_eq!(shared.phi(x), *v);
        assert_eq!(Oracle::new(&f).phi(x), *v);
    }
    // A lattice translate: phi(x - j) through weights equals direct phi.
    let x = &ps[0];
    let mut o = Oracle::new(&f);
    for (j, w) in o.weights(x) {
        let y: QVec = x.iter().zip(&j).map(|(a, &b)| a - &Q::int(b)).collect();
        assert_eq!(Oracle::new(&f).phi(&y), w);
    }
}

#[test]
fn oracle_timing_release() {
    for name in ["bcc12", "cc_tricubic", "bcc8", "bcc7", "fcc6"] {
        let f = catalog::get(name).unwrap();
        let points = pts(20, 17, &f, 5);
        let data: HashMap<IVec, i64> = HashMap::new();
        let data = std::cell::RefCell::new(data);
        let fetch = |j: &[i64]| -> Q {
            let mut d = data.borrow_mut();
            let n = d.len() as u64;
            let v = *d.entry(j.to_vec()).or_insert_with(|| ((n.wrapping_mul(2654435761) >> 3) % 201) as i64 - 100);
            Q::int(v)
        };
        let mut o = Oracle::new(&f);
        let start = Instant::now();
        for x in &points {
            let _ = o.spline_value(x, &fetch);
        }
        let el = start.elapsed();
        let (nodes, visits) = o.stats();
        let stencil = points.iter().map(|x| o.weights(x).len()).max().unwrap();
        println!(
            "oracle timing {name}: spline_value at 20 points in {:.1} ms, {nodes} nodes, {visits} memo misses, stencil <= {stencil}",
            el.as_secs_f64() * 1e3
        );
    }
}
