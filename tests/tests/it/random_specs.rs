//! "Any direction matrix": the seeded random specs of the derivation
//! benchmark (`boxforge::spec::random`) derive exactly or are refused at once
//! by a named cap; every cap has a spec that exceeds it.

use boxforge::derive::Derivation;
use boxforge::emit::{emit, EmitOptions};
use boxforge::error::Error;
use boxforge::eval::oracle::Oracle;
use boxforge::math::exact::Q;
use boxforge::math::linalg::{add_i, sub_q, QVec};
use boxforge::spec::lattice::Lattice;
use boxforge::spec::random::benchmark_specs;
use boxforge::spec::{Caps, Filter};

/// Every polynomial of (up to) three reference pieces per spec equals
/// de Boor's recurrence for phi at the piece's interior point, on a seeded
/// set of random specs (2D and 3D, 3-9 directions, entries in [-2, 2]).
#[test]
fn every_piece_equals_de_boor_on_seeded_random_specs() {
    let (mut pieces, mut specs) = (0, 0);
    for f in benchmark_specs(31, 45) {
        let d = match Derivation::new(&f) {
            Ok(d) => d,
            Err(Error::CellCap { .. } | Error::PolynomialCap { .. }) => continue,
            Err(e) => panic!("{:?} on {}: {e}", f.directions, f.lattice.name),
        };
        if d.polynomials() > 20_000 {
            continue; // the oracle is slow on the largest; the rest cover every lattice
        }
        // The estimate is a lower bound on the pieces and exact on the cells.
        assert_eq!(d.estimate.cells, d.arrangement.cells.len(), "{:?}", f.directions);
        assert!(d.estimate.reference_pieces <= d.references.len(), "{:?}", f.directions);
        let mut oracle = Oracle::new(&f);
        for (ri, r) in d.references.iter().enumerate().take(3) {
            let cell = &d.arrangement.cells[r.cell];
            let origin = d.cube_origin(&r.corner);
            let u = sub_q(&cell.interior, &origin);
            for (k, poly) in r.stencil.iter().zip(&d.forms(ri).polys) {
                let j: QVec = add_i(&r.corner, k).iter().map(|&x| Q::int(x)).collect();
                let expected = oracle.phi(&sub_q(&cell.interior, &j));
                assert_eq!(
                    poly.eval(&u),
                    expected,
                    "{:?} on {}, piece {ri}, offset {k:?}",
                    f.directions,
                    f.lattice.name
                );
                pieces += 1;
            }
        }
        specs += 1;
    }
    assert!(specs >= 30 && pieces >= 1000, "{specs} specs, {pieces} pieces compared");
}

fn spec(lattice: &str, directions: &[&[i64]], caps: Caps) -> Result<Filter, Error> {
    let l = Lattice::builtin(lattice).unwrap();
    Filter::new("capped", "", l, directions.iter().map(|d| d.to_vec()).collect(), caps)
}

/// The issue's seven-direction spec (over ten minutes before) needs about
/// half a million polynomials: refused by the estimate, before any cell is
/// cut, with the numbers and the knob in the message.
#[test]
fn the_issues_seven_direction_spec_is_refused_by_its_estimate() {
    let dirs: [&[i64]; 7] =
        [&[-2, 0, -2], &[1, 1, 1], &[1, -1, -2], &[1, -2, 1], &[1, 2, -2], &[1, 0, -1], &[2, -2, 0]];
    let f = spec("cc", &dirs, Caps::default()).unwrap();
    let e = Derivation::new(&f).expect_err("refused");
    match &e {
        Error::PolynomialCap { polynomials, exact, cap, .. } => {
            assert!(!exact, "refused by the estimate");
            assert!(*polynomials > 10 * cap, "{polynomials}");
        }
        other => panic!("{other}"),
    }
    assert!(e.to_string().contains("caps.max_polynomials"), "{e}");
}

/// One spec over each cap, each refused with the error that names it.
#[test]
fn every_cap_refuses_a_spec_that_exceeds_it() {
    let bcc7: [&[i64]; 7] = [&[1, 1, 1], &[-1, 1, 1], &[1, -1, 1], &[1, 1, -1], &[2, 0, 0], &[0, 2, 0], &[0, 0, 2]];
    let caps = |f: fn(&mut Caps)| {
        let mut c = Caps::default();
        f(&mut c);
        c
    };
    assert!(matches!(
        spec("bcc", &bcc7, caps(|c| c.max_directions = 6)),
        Err(Error::TooManyDirections { count: 7, cap: 6 })
    ));
    assert!(matches!(spec("bcc", &bcc7, caps(|c| c.max_degree = 3)), Err(Error::DegreeCap { degree: 4, cap: 3 })));
    let derive = |c: Caps| Derivation::new(&spec("bcc", &bcc7, c).unwrap());
    assert!(matches!(derive(caps(|c| c.max_stencil = 20)), Err(Error::StencilCap { cap: 20, .. })));
    // bcc7 has 24 cells; the refusal names a lower bound above the cap.
    assert!(matches!(derive(caps(|c| c.max_cells = 10)), Err(Error::CellCap { cells: 11..=24, cap: 10 })));
    assert!(derive(caps(|c| c.max_cells = 24)).is_ok());
    // bcc7: one reference piece of 30 samples, estimated exactly.
    assert!(matches!(
        derive(caps(|c| c.max_polynomials = 29)),
        Err(Error::PolynomialCap { exact: false, polynomials: 30, .. })
    ));
    // fcc6: estimated 1 x 16, but two reference pieces of 16: refused by the exact count.
    let fcc6 = boxforge::spec::catalog::get("fcc6").unwrap();
    let fcc6 = Filter::new("fcc6", "", fcc6.lattice, fcc6.directions, caps(|c| c.max_polynomials = 20)).unwrap();
    assert!(matches!(
        Derivation::new(&fcc6),
        Err(Error::PolynomialCap { exact: true, polynomials: 32, pieces: 2, .. })
    ));
    let d = derive(caps(|c| c.max_emitted_polynomials = 29)).unwrap();
    let e = emit(&d, &EmitOptions::default()).expect_err("over the emission cap");
    assert!(matches!(e, Error::EmitCap { polynomials: 30, cap: 29, .. }), "{e}");
    assert!(e.to_string().contains("caps.max_emitted_polynomials"));
    assert!(emit(&derive(Caps::default()).unwrap(), &EmitOptions::default()).is_ok());
}
