//! shaders-out/ holds the generated output for the catalog; this fails when
//! it is stale and names the command that refreshes it.

use std::path::Path;

const REFRESH: &str = "cargo run --release -p boxforge-runtime -- generate --all -o shaders-out";

#[test]
fn shaders_out_is_fresh() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../shaders-out");
    let command = "boxforge generate --all -o shaders-out";
    let mut expected = std::collections::BTreeSet::new();
    let mut stale = Vec::new();
    for d in boxforge_tests::all_catalog() {
        let files = boxforge::build::output::generated_files(
            &d,
            command,
            &boxforge::build::output::default_layouts(d.facts.dim),
            &boxforge::build::output::ALL_VARIANTS,
        )
        .unwrap();
        for (name, text) in files {
            if std::fs::read_to_string(dir.join(&name)).ok().as_deref() != Some(text.as_str()) {
                stale.push(name.clone());
            }
            expected.insert(name);
        }
    }
    let present: Vec<String> = std::fs::read_dir(&dir)
        .map(|rd| rd.filter_map(|e| e.ok()).map(|e| e.file_name().to_string_lossy().into_owned()).collect())
        .unwrap_or_default();
    let extra: Vec<String> =
        present.into_iter().filter(|n: &String| !n.starts_with('.') && !expected.contains(n)).collect();
    assert!(
        stale.is_empty() && extra.is_empty(),
        "shaders-out/ is stale (differs: {stale:?}; not generated: {extra:?}). Refresh it with:\n    {REFRESH}\nand commit the result."
    );
}
