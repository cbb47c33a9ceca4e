//! Generator benchmarks: exact derivation, WGSL emission and the full
//! `inspect` report for the built-in catalog.
//!
//! Run with `cargo bench -p boxforge --bench generator` (append `-- --quick`
//! for a faster, rougher pass, or a filter name to select benchmarks).

use boxforge::build::report::Report;
use boxforge::derive::Derivation;
use boxforge::emit::{emit, EmitOptions, Layout, Variant};
use boxforge::spec::{catalog, Filter};
use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, SamplingMode, Throughput};
use std::hint::black_box;
use std::time::Duration;

fn catalog_filters() -> Vec<Filter> {
    catalog::all().expect("catalog filters parse")
}

/// A complete derivation: `Derivation::new` plus every reference piece's
/// polynomial and BB forms, which are otherwise derived lazily on first use.
fn derive_full(filter: &Filter) -> Derivation {
    let d = Derivation::new(filter).expect("catalog filter derives");
    for i in 0..d.references.len() {
        black_box(d.forms(i));
    }
    d
}

fn fast_embedded() -> EmitOptions {
    EmitOptions { layout: Layout::Embedded, variant: Variant::Fast, ..EmitOptions::default() }
}

fn bench_derive(c: &mut Criterion) {
    let mut group = c.benchmark_group("derive");
    // Iterations take milliseconds: flat sampling fits 10 samples in the budget.
    group.sampling_mode(SamplingMode::Flat);
    for filter in catalog_filters() {
        group.bench_with_input(BenchmarkId::from_parameter(&filter.name), &filter, |b, f| {
            b.iter(|| derive_full(black_box(f)))
        });
    }
    group.finish();
}

fn bench_emit(c: &mut Criterion) {
    let mut group = c.benchmark_group("emit");
    // Iterations take milliseconds: flat sampling fits 10 samples in the budget.
    group.sampling_mode(SamplingMode::Flat);
    let opts = fast_embedded();
    for filter in catalog_filters() {
        // Built (and all lazy forms forced) outside the measurement.
        let d = derive_full(&filter);
        emit(&d, &opts).expect("catalog filter emits");
        group.bench_with_input(BenchmarkId::from_parameter(&filter.name), &d, |b, d| {
            b.iter(|| emit(black_box(d), black_box(&opts)).expect("emit"))
        });
    }
    group.finish();
}

fn bench_inspect_all(c: &mut Criterion) {
    let filters = catalog_filters();
    let mut group = c.benchmark_group("inspect_all");
    // Iterations take milliseconds: flat sampling fits 10 samples in the budget.
    group.sampling_mode(SamplingMode::Flat);
    group.throughput(Throughput::Elements(filters.len() as u64));
    group.bench_function("catalog", |b| {
        b.iter(|| {
            for f in &filters {
                let d = Derivation::new(black_box(f)).expect("catalog filter derives");
                black_box(Report::new(&d).to_json());
            }
        })
    });
    group.finish();
}

fn config() -> Criterion {
    Criterion::default()
        .sample_size(10)
        .warm_up_time(Duration::from_millis(500))
        .measurement_time(Duration::from_secs(2))
}

criterion_group! {
    name = benches;
    config = config();
    targets = bench_derive, bench_emit, bench_inspect_all
}
criterion_main!(benches);
