//! Dimension 4: the lattices z4, d4, d4star and the derivation of 4D box
//! splines, checked exactly against the independent de Boor recurrence
//! (piece values) and by prefiltered polynomial reproduction. The
//! 8-direction splines on D4 and D4* are heavier and live in `#[ignore]`d
//! tests (`cargo test -p boxforge-tests --test it d4 -- --ignored`).

use boxforge::build::report::Report;
use boxforge::derive::arrangement::Arrangement;
use boxforge::derive::Derivation;
use boxforge::emit::{emit, EmitOptions, FetchMode, Layout};
use boxforge::eval::oracle::Oracle;
use boxforge::math::exact::Q;
use boxforge::math::linalg::IVec;
use boxforge::spec::lattice::Lattice;
use boxforge::spec::{Caps, Filter};
use boxforge_tests::{data_at, eval_poly, prefiltered, random_interior_point, random_poly, Rng};
use std::time::Instant;

/// Prints the seconds a check took (on drop).
struct Timer(&'static str, String, Instant);
fn timer(what: &'static str, name: String) -> Timer {
    Timer(what, name, Instant::now())
}
impl Drop for Timer {
    fn drop(&mut self) {
        eprintln!("  {} {}: {:.2} s", self.1, self.0, self.2.elapsed().as_secs_f64());
    }
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
    let _t = timer("check_against_oracle", d.filter.name.clone());
    let mut oracle = Oracle::new(&d.filter);
    let mut rng = Rng(0xB0C5 ^ d.filter.name.len() as u64);
    let data = |j: &[i64]| Q::int(data_at(7, j));
    for _ in 0..points {
        let x = random_interior_point(d, &mut rng);
        let ours = d.eval_exact(&x, &data);
        assert_eq!(ours, oracle.spline_value(&x, &data), "{} at {x:?}", d.filter.name);
        if let Some(bb) = d.eval_exact_bb(&x, &data) {
            assert_eq!(bb, ours, "{}: BB form", d.filter.name);
        }
    }
}

/// Prefiltered data of a random polynomial of degree rho - 1 is reproduced
/// exactly; without the prefilter x_0^2 is not (when rho > 2).
fn check_reproduction(d: &Derivation, points: usize) {
    let _t = timer("check_reproduction", d.filter.name.clone());
    let rho = d.facts.approximation_order;
    let mut rng = Rng(11);
    let p = random_poly(4, rho - 1, &mut rng);
    let data = prefiltered(d, &p);
    for _ in 0..points {
        let x = random_interior_point(d, &mut rng);
        assert_eq!(d.eval_exact(&x, &data), eval_poly(&p, &x), "{} rho={rho}", d.filter.name);
        assert_eq!(d.eval_exact(&x, &|_| Q::one()), Q::one(), "{}: partition of unity", d.filter.name);
    }
    if rho > 2 {
        let sq = |j: &[i64]| Q::int(j[0] * j[0]);
        let x = random_interior_point(d, &mut rng);
        assert_ne!(d.eval_exact(&x, &sq), &x[0] * &x[0], "{}: x^2 without prefilter", d.filter.name);
    }
}

/// Cells counted before cutting (Möbius sum) = cells cut; the group has
/// the expected order; reference pieces cover the orbits.
fn check_structure(d: &Derivation, group: usize) {
    let _t = timer("check_structure", d.filter.name.clone());
    assert_eq!(d.group.len(), group, "{} group", d.filter.name);
    let frame = boxforge::derive::arrangement::Frame::new(&d.facts, &d.filter.lattice);
    let cut = Arrangement::new(&d.facts, &d.filter.lattice).cells.len();
    assert_eq!(frame.count_cells(), cut, "{}: counted vs cut cells", d.filter.name);
    assert_eq!(d.arrangement.cells.len(), cut);
    assert!(d.references.len() >= cut.div_ceil(group));
    assert_eq!(d.estimate.cells, cut);
}

/// A 4D derivation is reported without panicking; the emitter refuses what
/// 4D samples (a storage buffer) cannot do with one clear line: the bricked
/// layouts and linear fetches. (Emission itself, naga validation and the
/// branch-free proof of every 4D catalog filter are in wgsl.rs, and the
/// values on the device in the runtime's gpu_verify_4d.rs.)
fn check_report_and_emit(d: &Derivation) {
    let _t = timer("check_report_and_emit", d.filter.name.clone());
    let r = Report::new(d);
    assert_eq!(r.dimension, 4);
    assert!(r.to_text().contains("dimension 4"));
    assert!(!r.to_markdown().is_empty() && !r.to_json().is_empty());
    for (opts, what) in [
        (EmitOptions { layout: Layout::Bricked, ..EmitOptions::default() }, "bricked layout"),
        (EmitOptions { layout: Layout::BrickedPacked, ..EmitOptions::default() }, "bricked-packed layout"),
        (EmitOptions { fetch: FetchMode::Linear, layout: Layout::Packed, ..EmitOptions::default() }, "linear"),
    ] {
        let msg = emit(d, &opts).expect_err("refused in 4D").to_string();
        assert!(msg.contains(what) && msg.contains("storage buffer") && !msg.contains('\n'), "{msg}");
    }
}

#[test]
fn lattices_and_specs_in_4d() {
    for (name, det) in [("z4", 1), ("d4", 2), ("d4star", 8)] {
        let l = Lattice::builtin(name).unwrap();
        assert_eq!((l.dim(), l.det(), l.classes().len()), (4, det, det as usize), "{name}");
    }
    let d4 = Lattice::builtin("d4").unwrap();
    assert!(d4.contains(&[1, 1, 0, 0]) && d4.contains(&[1, -1, 1, 1]) && d4.contains(&[2, 0, 0, 0]));
    assert!(!d4.contains(&[1, 0, 0, 0]) && !d4.contains(&[1, 1, 1, 0]));
    let ds = Lattice::builtin("d4star").unwrap();
    assert!(ds.contains(&[1, 1, 1, 1]) && ds.contains(&[-1, 1, -1, 1]) && ds.contains(&[2, 0, 0, 0]));
    assert!(!ds.contains(&[1, 1, 0, 0]) && !ds.contains(&[1, 0, 0, 0]) && !ds.contains(&[2, 1, 1, 1]));
    // Spec text: 4-entry directions, the names, and a generator matrix.
    let t = "name=\"e\"\nlattice=\"d4star\"\ndirections=[[1,1,1,1],[-1,1,1,1],[1,-1,1,1],[1,1,-1,1],\
             [-1,-1,1,1],[-1,1,-1,1],[1,-1,-1,1],[-1,-1,-1,1]]\n";
    let f = Filter::from_toml(t, "t").unwrap();
    assert_eq!((f.dim(), f.directions.len(), f.lattice.det()), (4, 8, 8));
    let t = "name=\"g\"\nlattice={generators=[[2,0,0,0],[0,2,0,0],[0,0,2,0],[1,1,1,1]]}\n\
             directions=[[2,0,0,0],[0,2,0,0],[0,0,2,0],[1,1,1,1]]\n";
    assert_eq!(
        Filter::from_toml(t, "t").unwrap().lattice,
        Lattice::from_generators("custom", ds.generators.clone()).unwrap()
    );
    let bad = "name=\"b\"\nlattice=\"d4\"\ndirections=[[1,0,0,0],[0,1,0,0],[0,0,1,0],[0,0,0,1]]\n";
    assert!(matches!(Filter::from_toml(bad, "t"), Err(boxforge::error::Error::NotInLattice { index: 0, .. })));
    let mixed = "name=\"m\"\nlattice=\"z4\"\ndirections=[[1,0,0],[0,1,0,0]]\n";
    assert!(matches!(Filter::from_toml(mixed, "t"), Err(boxforge::error::Error::MixedDimensions { .. })));
}

#[test]
fn tensor_product_linear_and_cubic_on_z4() {
    for (name, times, rho) in [("z4_linear", 2, 2), ("z4_cubic", 4, 4)] {
        let (d, secs) = derive_timed(&filter(name, "z4", axes(times)));
        assert!(secs < 5.0, "{name}: {secs:.2} s (target under 1 s)");
        assert_eq!(d.facts.approximation_order, rho);
        check_structure(&d, 384);
        assert_eq!(d.max_stencil(), times.pow(4));
        check_against_oracle(&d, 60);
        check_reproduction(&d, 20);
        check_report_and_emit(&d);
    }
}

/// The centred cubic B-spline (knots -2..2).
fn cubic_bspline(t: &Q) -> Q {
    let a = t.abs();
    if a < Q::one() {
        &(&Q::frac(2, 3) - &(&a * &a)) + &(&a.pow(3) / &Q::int(2))
    } else if a < Q::int(2) {
        (&Q::int(2) - &a).pow(3) / Q::int(6)
    } else {
        Q::zero()
    }
}

#[test]
fn bcc7_times_cubic_bspline_in_t() {
    // BCC x Z, the seven bcc7 directions with t = 0, and e4 four times.
    let lattice = Lattice::from_generators(
        "bcc_x_z",
        vec![vec![-1, 1, 1, 0], vec![1, -1, 1, 0], vec![1, 1, -1, 0], vec![0, 0, 0, 1]],
    )
    .unwrap();
    let mut dirs: Vec<IVec> = vec![
        vec![1, 1, 1, 0],
        vec![-1, 1, 1, 0],
        vec![1, -1, 1, 0],
        vec![1, 1, -1, 0],
        vec![2, 0, 0, 0],
        vec![0, 2, 0, 0],
        vec![0, 0, 2, 0],
    ];
    dirs.extend(std::iter::repeat_n(vec![0, 0, 0, 1], 4));
    let f = Filter::new("bcc7_t_cubic", "", lattice, dirs, Caps::default()).unwrap();
    let (d, _) = derive_timed(&f);
    // 48 symmetries of the cube keep BCC and the bcc7 directions, times t -> -t.
    check_structure(&d, 96);
    check_against_oracle(&d, 40);
    // phi(x, t) = phi_bcc7(x) B3(t): the 3D catalog filter's own oracle times the cubic B-spline.
    let bcc7 = boxforge::spec::catalog::get("bcc7").unwrap();
    let mut o3 = Oracle::new(&bcc7);
    let mut rng = Rng(3);
    let delta = |j: &[i64]| if j.iter().all(|&x| x == 0) { Q::one() } else { Q::zero() };
    for _ in 0..40 {
        let x = random_interior_point(&d, &mut rng);
        let want = o3.phi(&x[..3]) * cubic_bspline(&x[3]);
        assert_eq!(d.eval_exact(&x, &delta), want, "at {x:?}");
    }
    check_reproduction(&d, 10);
    check_report_and_emit(&d);
}

fn eight_direction(lattice: &str, points: usize) -> Derivation {
    let (d, secs) = derive_timed(&filter(&format!("{lattice}_eight"), lattice, eight()));
    assert!(secs < 20.0, "{lattice}: {secs:.2} s (target 10 s)");
    check_structure(&d, 384);
    let t = Instant::now();
    check_against_oracle(&d, points);
    check_reproduction(&d, points / 4);
    eprintln!("{lattice}_eight: {points} oracle points + reproduction in {:.2} s", t.elapsed().as_secs_f64());
    check_report_and_emit(&d);
    d
}

/// FastSpline's published quasi-interpolants for the 8-direction spline
/// ("4D Examples" notebook, repository jjh13/fast-spline), as (offset,
/// weight): for D4*, 1 at the centre, -1/96 at the 8 points (+-8, 0, 0, 0)
/// and 1/288 at the 24 points (+-4, +-4, 0, 0); for D4, 7/3 at the centre
/// and -1/18 at the 24 points (+-1, +-1, 0, 0).
fn fastspline_quasi(lattice: &str) -> Vec<(Vec<i64>, Q)> {
    let perms = |v: [i64; 4]| -> Vec<Vec<i64>> {
        let mut out: Vec<Vec<i64>> = Vec::new();
        for signs in 0..16 {
            for order in
                [[0, 1, 2, 3], [1, 0, 2, 3], [2, 1, 0, 3], [3, 1, 2, 0], [0, 2, 1, 3], [0, 3, 2, 1], [2, 3, 0, 1]]
            {
                let mut p = vec![0; 4];
                for a in 0..4 {
                    p[order[a]] = if signs >> a & 1 == 1 { -v[a] } else { v[a] };
                }
                if !out.contains(&p) {
                    out.push(p);
                }
            }
        }
        out
    };
    let mut taps = vec![(vec![0; 4], if lattice == "d4" { Q::frac(7, 3) } else { Q::one() })];
    if lattice == "d4" {
        taps.extend(perms([1, 1, 0, 0]).into_iter().map(|k| (k, Q::frac(-1, 18))));
    } else {
        taps.extend(perms([8, 0, 0, 0]).into_iter().map(|k| (k, Q::frac(-1, 96))));
        taps.extend(perms([4, 4, 0, 0]).into_iter().map(|k| (k, Q::frac(1, 288))));
    }
    taps
}

#[test]
fn eight_directions_on_d4star() {
    let d = eight_direction("d4star", 30);
    // FastSpline's D4* quasi-interpolant differs from ours (33 taps reaching
    // 8 against 17 reaching 2: the centre and the 16 (+-1, +-1, +-1, +-1))
    // but meets the same conditions: taps on the lattice, sum 1, second
    // moments -2/3 per axis (minus the spline's), so with our derived
    // spline it too reproduces cubics; both are quasi-interpolants of order 4.
    let theirs = fastspline_quasi("d4star");
    assert_eq!((theirs.len(), d.prefilter.taps.len()), (33, 17));
    assert!(theirs.iter().all(|(k, _)| d.filter.lattice.contains(k)));
    let mut rng = Rng(29);
    let p = random_poly(4, 3, &mut rng);
    let data = |j: &[i64]| -> Q {
        theirs
            .iter()
            .map(|(k, w)| {
                let pt: Vec<Q> = j.iter().zip(k).map(|(a, b)| Q::int(a - b)).collect();
                w * &eval_poly(&p, &pt)
            })
            .sum()
    };
    for _ in 0..6 {
        let x = random_interior_point(&d, &mut rng);
        assert_eq!(d.eval_exact(&x, &data), eval_poly(&p, &x), "FastSpline's D4* quasi-interpolant at {x:?}");
    }
    // The check can fail: the same taps with the outer shell halved in
    // reach (second moment +1/3 per axis instead of -2/3) do not reproduce x^2.
    let wrong: Vec<(Vec<i64>, Q)> = theirs
        .iter()
        .map(|(k, w)| (k.iter().map(|&a| if a.abs() == 8 { a / 2 } else { a }).collect(), w.clone()))
        .collect();
    let sq = |j: &[i64]| -> Q { wrong.iter().map(|(k, w)| w * &Q::int((j[0] - k[0]) * (j[0] - k[0]))).sum() };
    let x = random_interior_point(&d, &mut rng);
    assert_ne!(d.eval_exact(&x, &sq), &x[0] * &x[0]);
}

#[test]
fn eight_directions_on_d4() {
    let d = eight_direction("d4", 30);
    // On D4 the derived prefilter is FastSpline's, tap for tap.
    let mut ours: Vec<(Vec<i64>, Q)> = d.prefilter.taps.clone();
    let mut theirs = fastspline_quasi("d4");
    ours.sort_by(|a, b| a.0.cmp(&b.0));
    theirs.sort_by(|a, b| a.0.cmp(&b.0));
    assert_eq!(ours, theirs);
}

/// The same at many more points (minutes of de Boor recursion).
#[test]
#[ignore]
fn eight_directions_many_points() {
    eight_direction("d4star", 400);
    eight_direction("d4", 400);
}

/// The plan of the emitted code (point location, fetch order) evaluated on
/// the CPU agrees with the exact evaluator in 4D too.
fn check_plan(d: &Derivation, points: usize) {
    let _t = timer("check_plan", d.filter.name.clone());
    let plan = boxforge::emit::plan::Plan::new(d);
    assert!(plan.fetches() >= d.max_stencil());
    let mut rng = Rng(5);
    let data = |j: &[i64]| data_at(3, j) as f64;
    for _ in 0..points {
        let x: Vec<f64> = random_interior_point(d, &mut rng).iter().map(|q| q.to_f64()).collect();
        let (v, g) = plan.eval_f64(d, &x, &data);
        let (w, h) = d.eval_f64(&x, &data);
        assert!((v - w).abs() < 1e-9 * (1.0 + w.abs()), "{} plan {v} vs {w}", d.filter.name);
        assert!(g.iter().zip(&h).all(|(a, b)| (a - b).abs() < 1e-8 * (1.0 + b.abs())), "{}", d.filter.name);
    }
}

#[test]
fn plan_and_fetch_order_in_4d() {
    for f in [filter("z4_linear", "z4", axes(2)), filter("d4star_eight", "d4star", eight())] {
        let d = Derivation::new(&f).unwrap();
        check_plan(&d, 30);
    }
}

/// Seeded random direction sets (up to 6 directions, entries in -1..=1) on
/// the three 4D lattices: counted = cut cells, values = de Boor.
#[test]
fn random_4d_direction_sets() {
    let mut rng = Rng(0x4D4D);
    let mut done = 0;
    while done < 12 {
        let lattice = ["z4", "d4", "d4star"][done % 3];
        let l = Lattice::builtin(lattice).unwrap();
        let n = rng.range(4, 6) as usize;
        let dirs: Vec<IVec> = (0..n)
            .map(|_| {
                let v: IVec = (0..4).map(|_| rng.range(-1, 1)).collect();
                // Into the lattice: double it when it is not a lattice point.
                if l.contains(&v) {
                    v
                } else {
                    v.iter().map(|x| 2 * x).collect()
                }
            })
            .collect();
        let Ok(f) = Filter::new("r", "", l, dirs, Caps::default()) else { continue };
        let d = match Derivation::new(&f) {
            Ok(d) => d,
            Err(e) => {
                eprintln!("{lattice} {:?}: {e}", f.directions);
                continue;
            }
        };
        eprintln!(
            "{lattice} {:?}: {} cells, {} references",
            f.directions,
            d.arrangement.cells.len(),
            d.references.len()
        );
        let cut = Arrangement::new(&d.facts, &d.filter.lattice).cells.len();
        assert_eq!(d.estimate.cells, cut, "{:?}", f.directions);
        check_against_oracle(&d, 5);
        done += 1;
    }
}

/// Where the time of the 8-direction derivations goes, stage by stage
/// (printed; run with --ignored --nocapture).
#[test]
#[ignore]
fn stage_timings() {
    use boxforge::derive::arrangement::Frame;
    use boxforge::derive::spline::SplineFacts;
    for lattice in ["d4star", "d4"] {
        let f = filter(&format!("{lattice}_eight"), lattice, eight());
        let t = Instant::now();
        let facts = SplineFacts::new(&f);
        let frame = Frame::new(&facts, &f.lattice);
        let planes: usize = (0..frame.classes.len()).map(|c| frame.crossing_planes(c).len()).sum();
        let counted = frame.count_cells();
        let t_count = t.elapsed().as_secs_f64();
        let t = Instant::now();
        let cut = Arrangement::new(&facts, &f.lattice).cells.len();
        let t_cut = t.elapsed().as_secs_f64();
        let t = Instant::now();
        let group = boxforge::derive::symmetry::point_group(&f);
        let t_group = t.elapsed().as_secs_f64();
        let t = Instant::now();
        let pre = boxforge::derive::prefilter::derive_prefilter(&f, &group, facts.approximation_order).unwrap();
        let t_pre = t.elapsed().as_secs_f64();
        let t = Instant::now();
        let d = Derivation::new(&f).unwrap();
        let t_new = t.elapsed().as_secs_f64();
        let t = Instant::now();
        d.derive_all_forms(&|_, _| {});
        let t_forms = t.elapsed().as_secs_f64();
        let simplices = d.references.iter().filter(|r| r.is_simplex).count();
        eprintln!(
            "{lattice}: {planes} crossing planes over {} cubes; count {counted} cells {t_count:.2} s; cut {cut} cells {t_cut:.2} s; \
             group {} {t_group:.2} s; prefilter {} taps {t_pre:.2} s; Derivation::new (all of these + maps + stencils) {t_new:.2} s; \
             forms of {} references ({simplices} simplices, {} polynomials) {t_forms:.2} s",
            frame.classes.len(),
            group.len(),
            pre.taps.len(),
            d.references.len(),
            d.polynomials()
        );
    }
}

/// The cell maps (found by class and centroid since the 4D work) still send
/// every 2D/3D catalog filter's cells onto reference pieces that agree with
/// the de Boor recurrence.
#[test]
fn catalog_maps_agree_with_the_oracle() {
    for f in boxforge::spec::catalog::all().unwrap() {
        let d = Derivation::new(&f).unwrap();
        if d.polynomials() > 3000 {
            continue;
        }
        check_against_oracle(&d, 10);
    }
}
