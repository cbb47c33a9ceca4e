//! Replays the fuzz corpora (`fuzz/corpus/`, minimised after each fuzz run;
//! see docs/FUZZING.md) and their seeds (the catalog specs, the generated
//! modules of `shaders-out/`) through the same calls as the fuzz targets, so
//! the inputs that once found a crash keep being checked on stable Rust in CI.

use boxforge::derive::Derivation;
use boxforge::spec::Filter;
use std::path::Path;

/// Every file of the target's corpus, then the seed folder's files ending in `seed_ext`.
fn corpus(target: &str, seeds: &str, seed_ext: &str) -> Vec<Vec<u8>> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let list = |dir: &Path| {
        let mut files: Vec<_> = std::fs::read_dir(dir)
            .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
            .map(|e| e.unwrap().path())
            .collect();
        files.sort();
        files
    };
    let mut files = list(&root.join("fuzz/corpus").join(target));
    files.extend(list(&root.join(seeds)).into_iter().filter(|p| p.to_string_lossy().ends_with(seed_ext)));
    files.iter().map(|p| std::fs::read(p).unwrap()).collect()
}

#[test]
fn spec_corpus_parses_and_derives_without_panics() {
    let inputs = corpus("spec_derive", "generator/catalog", ".toml");
    assert!(inputs.len() >= 10, "{} inputs", inputs.len());
    let mut derived = 0;
    for data in &inputs {
        let Ok(text) = std::str::from_utf8(data) else { continue };
        let Ok(mut filter) = Filter::from_toml(text, "fuzz") else { continue };
        filter.caps.max_cells = filter.caps.max_cells.min(64);
        filter.caps.max_polynomials = filter.caps.max_polynomials.min(256);
        filter.caps.max_stencil = filter.caps.max_stencil.min(64);
        if filter.directions.len() > 6 || filter.directions.iter().flatten().any(|x| x.abs() > 3) {
            continue;
        }
        if let Ok(d) = Derivation::new(&filter) {
            d.derive_all_forms(&|_, _| {});
            derived += 1;
        }
    }
    assert!(derived >= 5, "{derived} of {} inputs derived", inputs.len());
}

#[test]
fn wgsl_corpus_validates_without_panics() {
    let inputs = corpus("validate_wgsl", "shaders-out", ".wgsl");
    assert!(inputs.len() >= 3, "{} inputs", inputs.len());
    for data in &inputs {
        let Ok(text) = std::str::from_utf8(data) else { continue };
        let report = boxforge::validate::validate_wgsl(text, "fuzz.wgsl");
        let _ = boxforge::validate::check_branch_free(&report, &["f_eval", "f_eval_grad"]);
    }
}
