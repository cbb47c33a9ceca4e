//! CI runs a small smoke version of the benchmark: it must run end to end and
//! produce every section (no timed assertions).

#[test]
fn bench_smoke_runs_and_reports_every_section() {
    let gpu = crate::common::gpu();
    let o = boxforge_runtime::bench::BenchOptions::smoke();
    let r = boxforge_runtime::bench::run(gpu, &o, &|_| {}).unwrap();
    for kind in ["eval", "eval_grad", "central_differences"] {
        assert!(r.rows.iter().any(|x| x.kind == kind && x.evals_per_s.unwrap_or(0.0) > 0.0), "{kind}");
    }
    assert!(r.rows.iter().any(|x| x.variant == "naive" && x.ratio_to_baseline.is_some()));
    assert!(r.rows.iter().any(|x| x.layout == "packed" && x.baseline.as_deref() == Some("packed ÷ embedded")));
    assert!(r.rows.iter().any(|x| x.ms_per_frame.is_some()));
    assert!(!r.quality.is_empty() && !r.convergence.is_empty() && !r.gradient.is_empty());
    // bcc_linear reproduces linear functions: its measured order is near 2.
    let c = &r.convergence[0];
    assert!(c.measured_order > 1.5, "{c:?}");
    let md = boxforge_runtime::bench::markdown(&r, "test");
    assert!(md.contains("## Evaluation throughput") && md.contains("## Convergence"));
}

/// `bench --literature` end to end at a small size: every scheme measured,
/// projected tetrahedra on both lattices, a verdict for every claim.
#[test]
fn literature_bench_measures_every_scheme_and_judges_every_claim() {
    use boxforge_runtime::bench::literature;
    let gpu = crate::common::gpu();
    let r = literature::run(gpu, 2048, 1, 24, None, &|_| {}).unwrap();
    assert_eq!(r.schemes.len(), 9);
    for s in &r.schemes {
        // Every scheme reconstructs Marschner-Lobb at 41^3 to a few percent (the function spans [0, 1]).
        assert!(s.rms_error.is_finite() && s.rms_error < 0.1, "{s:?}");
        assert!(s.evals_per_s > 0.0, "{s:?}");
    }
    assert_eq!(r.pt.iter().map(|p| p.lattice.as_str()).collect::<Vec<_>>(), ["bcc", "cc"]);
    assert!(r.mni.is_empty(), "no head given, no head rows");
    assert!(r.pt.iter().all(|p| p.tetrahedra_drawn > 0 && p.ms_per_frame > 0.0));
    let v = literature::verdicts(&r);
    assert_eq!(v.len(), 5);
    assert!(v.iter().all(|x| x.confirmed.is_some()));
    let md = literature::markdown(&r, "test");
    assert!(md.contains("## Renderers of the literature") && md.contains("confirmed?"));
}

/// `bench --perm` end to end on Marschner-Lobb: every filter at every N
/// built and timed against direct evaluation, the memory it reports within
/// 1% of the paper's formula, and finer quantization closer to direct.
#[test]
fn perm_bench_measures_every_filter_and_n() {
    use boxforge_runtime::bench::perm;
    let gpu = crate::common::gpu();
    let r = perm::run(gpu, None, 24, 1, &|_| {}).unwrap();
    assert!(r.refused.is_empty(), "{:?}", r.refused);
    assert_eq!(r.rows.len(), perm::FILTERS.len() * (perm::QUANTS.len() + 2));
    for x in &r.rows {
        let off = (x.memory.total() as f64 / x.formula_bytes as f64 - 1.0).abs();
        assert!(off < 0.01, "{} N={}: {} bytes vs formula {}", x.filter, x.density, x.memory.total(), x.formula_bytes);
        assert!(x.direct_ms > 0.0 && x.perm_ms > 0.0 && x.speedup.rounds == 1, "{x:?}");
    }
    for f in perm::FILTERS {
        let rms =
            |n: u32| r.rows.iter().find(|x| x.filter == f && x.density == n && x.gradient == n && !x.peel).unwrap().rms;
        // Peeling leaves the image (so its RMS against direct) as it was and only drops candidates.
        let peeled = r.rows.iter().find(|x| x.filter == f && x.peel).unwrap();
        let unpeeled = r
            .rows
            .iter()
            .rfind(|x| x.filter == f && !x.peel && x.tf == peeled.tf && (x.density, x.gradient) == perm::PEELED)
            .unwrap();
        assert_eq!(peeled.rms, unpeeled.rms, "{f}");
        assert_eq!(peeled.candidates + peeled.peeled, unpeeled.candidates, "{f}");
        assert!(rms(10) < rms(3), "{f}: RMS at N=10 {:.2} vs N=3 {:.2}", rms(10), rms(3));
    }
    let md = perm::markdown(&r, "test");
    assert!(md.contains("## PERM (Lim and Shin)") && md.contains("| bcc12 | marschner-lobb | 10 | 10 | no |"), "{md}");
}

/// `bench --hessian` end to end at a small size: cc_tricubic's
/// eval_hessian against central differences and the hand-written separable
/// tricubic Hessian, which must compute the same Hessian (the separable one
/// to f32 rounding: an independent check of the generated factored form).
#[test]
fn hessian_bench_times_both_rivals_after_they_agree() {
    use boxforge_runtime::bench::hessian;
    let gpu = crate::common::gpu();
    let r = hessian::run(gpu, &["cc_tricubic".to_string(), "bcc_linear".to_string()], 2048, 1, &|_| {}).unwrap();
    // bcc_linear (degree 1) has no eval_hessian: no rows for it.
    assert_eq!(r.rows.len(), 2, "{r:?}");
    for row in &r.rows {
        assert_eq!(row.filter, "cc_tricubic");
        assert!(row.agrees, "{row:?}");
        assert!(row.generated_evals_per_s > 0.0 && row.rival_evals_per_s > 0.0, "{row:?}");
    }
    let separable = r.rows.iter().find(|x| x.rival == "separable tricubic").unwrap();
    assert!(separable.max_rel_diff < 1e-5, "{separable:?}");
    let md = hessian::markdown(&r, "test");
    assert!(md.contains(hessian::SECTION_START) && md.contains("separable tricubic"));
}

/// `bench --four-d`'s parts: the RMS falls as the budget grows, a filter of
/// approximation order 2 has no prefilter to apply (prefiltered = plain),
/// the 4D modules time, and the verdict names the winner per budget.
#[test]
fn four_d_bench_measures_rms_and_rates() {
    use boxforge_runtime::bench::four;
    let gpu = crate::common::gpu();
    let d = |n: &str| boxforge::derive::Derivation::new(&boxforge::spec::catalog::get(n).unwrap()).unwrap();
    let (z4, d4s) = (d("z4_linear"), d("d4star8"));
    let coarse = four::quality(gpu, &z4, 12, 2000).unwrap();
    let fine = four::quality(gpu, &z4, 40, 2000).unwrap();
    assert!(fine.rms_prefiltered < 0.8 * coarse.rms_prefiltered, "{coarse:?} {fine:?}");
    assert_eq!(coarse.rms_prefiltered, coarse.rms_plain, "z4_linear's prefilter is the identity");
    assert_eq!(coarse.samples, 11usize.pow(4), "11 points per axis of [-1, 1] at spacing 2/11");
    let q = four::quality(gpu, &d4s, 12, 2000).unwrap();
    assert!(q.rms_prefiltered.is_finite() && q.rms_prefiltered != q.rms_plain, "{q:?}");
    // Matched density: within 15% of Z^4's count inside the domain.
    assert!((q.samples as f64 / coarse.samples as f64 - 1.0).abs() < 0.15, "{q:?}");
    let speed = four::speed(gpu, &d4s, 1000, 1).unwrap();
    assert!(speed.evals_per_s > 0.0 && speed.fetches == 60, "{speed:?}");
    let v = four::verdicts(&[coarse.clone(), q.clone()]);
    assert_eq!(v.len(), 1);
    let wins = q.rms_prefiltered < coarse.rms_prefiltered;
    assert_eq!(v[0].contains("D4* wins"), wins, "{v:?}");
}

/// `bench --pyramid`'s measurement: level 0 is the same samples whatever
/// the reduction (equal RMS), a coarser level loses detail (larger RMS),
/// and no reduction's error is past 3x the lowest at its level.
#[test]
fn pyramid_bench_measures_every_level_and_reduction() {
    use boxforge_runtime::bench::levels;
    let d = boxforge::derive::Derivation::new(&boxforge::spec::catalog::get("cc_trilinear").unwrap()).unwrap();
    let scratch = std::env::temp_dir().join(format!("boxforge-pyramid-bench-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&scratch);
    std::fs::create_dir_all(&scratch).unwrap();
    let r = levels::measure(&[d], 33, 3, 500, &scratch, &|_| {}).unwrap();
    let _ = std::fs::remove_dir_all(&scratch);
    assert_eq!(r.rows.len(), 3, "{r:?}");
    let l0 = &r.rows[0].rms;
    assert!(l0.iter().all(|v| *v == l0[0] && *v > 0.0 && v.is_finite()), "{l0:?}");
    for row in &r.rows[1..] {
        for (reduction, v) in levels::REDUCTIONS.iter().zip(&row.rms) {
            assert!(*v > l0[0], "{reduction:?} level {}: {v} vs level 0's {}", row.level, l0[0]);
            assert!(
                *v < 3.0 * row.rms.iter().copied().fold(f64::INFINITY, f64::min),
                "{reduction:?} level {}: {:?}",
                row.level,
                row.rms
            );
        }
    }
    assert_eq!((r.rows[1].edge, r.rows[2].edge), (17, 9));
    assert!(levels::markdown(&r, "test").contains(levels::SECTION_START));
}
