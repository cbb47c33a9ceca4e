//! Property tests: random valid direction matrices (2D and 3D, up to 7
//! directions, entries in -2..=2) on every built-in lattice that contains
//! them derive without error (or are refused by a size cap), form a
//! partition of unity, and match the oracle.
//! Raise the case count with PROPTEST_CASES.

use boxforge::derive::Derivation;
use boxforge::error::Error;
use boxforge::eval::oracle::Oracle;
use boxforge::math::exact::Q;
use boxforge::spec::lattice::{Lattice, BUILTIN_LATTICES};
use boxforge::spec::{Caps, Filter};
use boxforge_tests::{data_at, random_interior_point, Rng};
use proptest::prelude::*;

/// Non-zero lattice vectors with entries in -2..=2.
fn lattice_vectors(l: &Lattice) -> Vec<Vec<i64>> {
    let s = l.dim();
    let mut out = Vec::new();
    let mut v = vec![-2i64; s];
    loop {
        if v.iter().any(|&x| x != 0) && l.contains(&v) {
            out.push(v.clone());
        }
        let mut k = 0;
        loop {
            if k == s {
                return out;
            }
            v[k] += 1;
            if v[k] <= 2 {
                break;
            }
            v[k] = -2;
            k += 1;
        }
    }
}

/// The built-in 2D and 3D lattices (4D random specs: `d4.rs`).
fn lattices_2d_3d() -> Vec<&'static str> {
    BUILTIN_LATTICES.iter().copied().filter(|n| Lattice::builtin(n).is_ok_and(|l| l.dim() <= 3)).collect()
}

fn filter_strategy() -> impl Strategy<Value = Filter> {
    prop::sample::select(lattices_2d_3d()).prop_flat_map(|name| {
        let l = Lattice::builtin(name).unwrap();
        let s = l.dim();
        let vs = lattice_vectors(&l);
        prop::collection::vec(prop::sample::select(vs), s..=7).prop_filter_map("directions must span", move |dirs| {
            Filter::new("random", "", l.clone(), dirs, Caps::default()).ok()
        })
    })
}

fn cases() -> u32 {
    std::env::var("PROPTEST_CASES").ok().and_then(|v| v.parse().ok()).unwrap_or(24)
}

proptest! {
    #![proptest_config(ProptestConfig { cases: cases(), max_shrink_iters: 64, ..ProptestConfig::default() })]

    #[test]
    fn random_direction_matrices_derive_and_agree(filter in filter_strategy(), seed in any::<u64>()) {
        let d = match Derivation::new(&filter) {
            Ok(d) => d,
            // Too large to derive by default: an honest refusal, not a failure.
            Err(Error::CellCap { .. } | Error::PolynomialCap { .. }) => return Ok(()),
            Err(e) => return Err(TestCaseError::fail(format!("{:?}: {e}", filter.directions))),
        };
        let mut oracle = Oracle::new(&filter);
        let mut rng = Rng(seed);
        let data = |j: &[i64]| Q::int(data_at(seed, j));
        for _ in 0..6 {
            let x = random_interior_point(&d, &mut rng);
            prop_assert_eq!(d.eval_exact(&x, &|_| Q::one()), Q::one(), "partition of unity for {:?}", &filter.directions);
            prop_assert_eq!(d.eval_exact(&x, &data), oracle.spline_value(&x, &data), "oracle for {:?}", &filter.directions);
        }
    }
}

/// Small random filters (entries in -1..=1, up to 5 directions) emit WGSL
/// that validates and whose eval functions are branch-free.
fn small_filter_strategy() -> impl Strategy<Value = Filter> {
    prop::sample::select(lattices_2d_3d()).prop_flat_map(|name| {
        let l = Lattice::builtin(name).unwrap();
        let s = l.dim();
        let vs: Vec<Vec<i64>> = lattice_vectors(&l).into_iter().filter(|v| v.iter().all(|x| x.abs() <= 1)).collect();
        let vs = if vs.len() < s { lattice_vectors(&l) } else { vs };
        prop::collection::vec(prop::sample::select(vs), s..=s + 2)
            .prop_filter_map("directions must span", move |dirs| {
                Filter::new("rnd", "", l.clone(), dirs, Caps::default()).ok()
            })
    })
}

proptest! {
    #![proptest_config(ProptestConfig { cases: cases(), max_shrink_iters: 32, ..ProptestConfig::default() })]

    #[test]
    fn random_filters_emit_valid_branch_free_wgsl(filter in small_filter_strategy()) {
        use boxforge::emit::{emit, EmitOptions, Layout};
        let d = Derivation::new(&filter).map_err(|e| TestCaseError::fail(e.to_string()))?;
        if d.polynomials() > filter.caps.max_emitted_polynomials {
            return Ok(()); // refused by the emission cap (tested in random_specs.rs)
        }
        for layout in [Layout::Embedded, Layout::Packed] {
            let e = emit(&d, &EmitOptions { layout, ..EmitOptions::default() }).map_err(|e| TestCaseError::fail(e.to_string()))?;
            let r = boxforge::validate::validate_wgsl(&e.source, &e.file_name);
            prop_assert!(r.valid, "{:?}: {}", filter.directions, r.error.clone().unwrap_or_default());
            boxforge::validate::check_branch_free(&r, &["rnd_eval", "rnd_eval_grad"]).map_err(TestCaseError::fail)?;
            prop_assert_eq!(r.function("rnd_eval").unwrap().total_loads, e.stats.fetches_per_eval);
        }
    }
}
