//! CI runs a small smoke version of the benchmark: it must run end to end and
//! produce every section (no timed assertions).

#[test]
fn bench_smoke_runs_and_reports_every_section() {
    let gpu = boxforge_runtime::gpu::Gpu::new(None).unwrap_or_else(|e| panic!("{e}"));
    let o = boxforge_runtime::bench::BenchOptions::smoke();
    let r = boxforge_runtime::bench::run(&gpu, &o, &|_| {}).unwrap();
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
