//! The typed stubs (`python/boxforge/_boxforge.pyi`) declare every function
//! the extension module registers (`src/lib.rs`), and nothing it does not:
//! a function added without its stub, or a stub left behind, fails here.
//! (This test is also what makes `cargo test --workspace` build the
//! extension, which scripts/python/test.sh then imports.)

use std::collections::BTreeSet;

fn registered(lib: &str) -> BTreeSet<String> {
    lib.match_indices("wrap_pyfunction!(")
        .map(|(i, m)| {
            let rest = &lib[i + m.len()..];
            let path = &rest[..rest.find(',').expect("wrap_pyfunction!(path, m)")];
            path.rsplit("::").next().unwrap().trim().to_string()
        })
        .collect()
}

fn stubbed(pyi: &str) -> BTreeSet<String> {
    pyi.lines()
        .filter_map(|l| l.strip_prefix("def "))
        .map(|l| l[..l.find('(').expect("def name(")].to_string())
        .collect()
}

#[test]
fn every_registered_function_has_a_stub_and_every_stub_a_function() {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR"));
    let lib = std::fs::read_to_string(dir.join("src/lib.rs")).unwrap();
    let pyi = std::fs::read_to_string(dir.join("boxforge/_boxforge.pyi")).unwrap();
    let (r, s) = (registered(&lib), stubbed(&pyi));
    assert!(r.len() >= 5, "found {r:?} in src/lib.rs");
    assert_eq!(r, s, "src/lib.rs registers {r:?}; _boxforge.pyi declares {s:?}");
}

#[test]
fn the_check_sees_a_missing_stub() {
    let r = registered("m.add_function(wrap_pyfunction!(spec::shader, m)?)?;");
    assert_eq!(r, BTreeSet::from(["shader".to_string()]));
    assert_ne!(r, stubbed("def report_json(spec: str) -> str: ..."));
}
