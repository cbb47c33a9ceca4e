//! `boxforge validate` on arbitrary text: naga's parse and validation plus
//! the branch-free proof never panic. Replayed by `tests/tests/fuzz_corpus.rs`.
#![no_main]
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else { return };
    let report = boxforge::validate::validate_wgsl(text, "fuzz.wgsl");
    let _ = boxforge::validate::check_branch_free(&report, &["f_eval", "f_eval_grad"]);
});
