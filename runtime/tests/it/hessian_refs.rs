//! The hand-written Hessian rivals of `boxforge bench --hessian`: Kim's bcc7
//! (runtime/references/kim_bcc7_hessian.wgsl) and Kim & Kim 2023's cc6
//! (runtime/references/kim_kim_cc6_hessian.wgsl) compute the same value,
//! gradient and Hessian as the generated `eval_hessian` (to f32 rounding),
//! and the cc6 catalog entry they are timed against passes `verify`.

use boxforge::derive::Derivation;
use boxforge::emit::{Layout, Variant};
use boxforge_runtime::bench::hessian;

#[test]
fn kim_rivals_agree_with_the_generated_hessian() {
    let gpu = crate::common::gpu();
    let r = hessian::run(gpu, &["bcc7".into(), "cc6".into()], 2048, 1, &|_| {}).unwrap();
    for row in &r.rows {
        assert!(row.agrees, "{row:?}");
        assert!(row.generated_evals_per_s > 0.0 && row.rival_evals_per_s > 0.0, "{row:?}");
    }
    for (filter, rival) in [("bcc7", hessian::KIM_BCC7), ("cc6", hessian::KIM_KIM_CC6)] {
        let row = r.rows.iter().find(|x| x.filter == filter && x.rival == rival);
        let row = row.unwrap_or_else(|| panic!("no {rival} row for {filter}: {r:?}"));
        // Exact rivals: f32 rounding, not a truncation error.
        assert!(row.max_rel_diff < 1e-5, "{row:?}");
        // All points, but for C^1 cc6 those within KNOT_GAP of a knot plane.
        assert!(row.compared_points * 100 >= r.points * 99, "{row:?}");
        assert!(row.fetches_rival.is_some() && row.ops_rival.is_some(), "{row:?}");
    }
    let md = hessian::markdown(&r, "test");
    assert!(md.contains(hessian::KIM_BCC7) && md.contains(hessian::KIM_KIM_CC6), "{md}");
}

#[test]
fn cc6_passes_verify_on_the_device() {
    let gpu = crate::common::gpu();
    let d = Derivation::new(&boxforge::spec::catalog::get("cc6").unwrap()).unwrap();
    let r = boxforge_runtime::verify::verify(gpu, &d, Layout::Embedded, Variant::Fast, 2000, 7).unwrap();
    assert!(r.passed, "{r:?}");
    assert!(r.max_rel_hessian_err.is_some(), "cc6 has eval_hessian: {r:?}");
}
