//! No hand-written Rust file over 600 lines: a file that long has more than
//! one job (see "How we like code" in the project guide). Every `.rs` file of
//! the workspace's crates, tests and examples counts, tests included, with
//! the number of lines `wc -l` would print.

use std::path::{Path, PathBuf};

/// The longest a hand-written Rust file may be.
const MAX_LINES: usize = 600;

fn rust_files(dir: &Path, out: &mut Vec<PathBuf>) {
    let Ok(entries) = std::fs::read_dir(dir) else { return };
    for e in entries {
        let p = e.unwrap().path();
        let name = p.file_name().unwrap().to_string_lossy().into_owned();
        if p.is_dir() {
            // Build output and dependencies are not ours.
            if !matches!(name.as_str(), "target" | "node_modules" | ".git") {
                rust_files(&p, out);
            }
        } else if name.ends_with(".rs") {
            out.push(p);
        }
    }
}

/// `(lines, path)` of each file under `roots` longer than `max`.
fn too_long(roots: &[PathBuf], max: usize) -> Vec<(usize, PathBuf)> {
    let mut files = Vec::new();
    for r in roots {
        rust_files(r, &mut files);
    }
    let mut long: Vec<(usize, PathBuf)> = files
        .into_iter()
        .map(|f| (std::fs::read_to_string(&f).unwrap().lines().count(), f))
        .filter(|(n, _)| *n > max)
        .collect();
    long.sort();
    long
}

#[test]
fn the_size_check_finds_a_long_file() {
    let dir = std::env::temp_dir().join(format!("boxforge-sizes-{}", std::process::id()));
    std::fs::create_dir_all(dir.join("src/target")).unwrap();
    std::fs::write(dir.join("src/long.rs"), "//\n".repeat(MAX_LINES + 1)).unwrap();
    std::fs::write(dir.join("src/short.rs"), "//\n".repeat(MAX_LINES)).unwrap();
    std::fs::write(dir.join("src/target/built.rs"), "//\n".repeat(2 * MAX_LINES)).unwrap();
    let long = too_long(std::slice::from_ref(&dir), MAX_LINES);
    std::fs::remove_dir_all(&dir).unwrap();
    assert_eq!(long, vec![(MAX_LINES + 1, dir.join("src/long.rs"))]);
}

#[test]
fn no_rust_file_is_over_600_lines() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let roots: Vec<PathBuf> =
        ["generator", "runtime", "tests", "examples", "fuzz"].iter().map(|d| root.join(d)).collect();
    let long = too_long(&roots, MAX_LINES);
    let list: Vec<String> =
        long.iter().map(|(n, p)| format!("{} ({n} lines)", p.strip_prefix(&root).unwrap_or(p).display())).collect();
    assert!(
        list.is_empty(),
        "over {MAX_LINES} lines (split each along its seams into files with one job): {}",
        list.join(", ")
    );
}
