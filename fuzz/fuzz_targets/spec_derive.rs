//! Spec parsing and derivation with small caps: any bytes give a filter or
//! a clear error, never a panic or a hang. The corpus is replayed by
//! `tests/tests/fuzz_corpus.rs` in the normal test suite.
#![no_main]
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else { return };
    let Ok(mut filter) = boxforge::spec::Filter::from_toml(text, "fuzz") else { return };
    // Small caps keep every accepted spec quick to derive.
    filter.caps.max_cells = filter.caps.max_cells.min(64);
    filter.caps.max_polynomials = filter.caps.max_polynomials.min(256);
    filter.caps.max_stencil = filter.caps.max_stencil.min(64);
    if filter.directions.len() > 6 || filter.directions.iter().flatten().any(|x| x.abs() > 3) {
        return;
    }
    if let Ok(d) = boxforge::derive::Derivation::new(&filter) {
        d.derive_all_forms(&|_, _| {});
    }
});
