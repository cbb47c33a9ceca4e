//! `scripts/gpu-bench.sh` in its small size on lavapipe, so that the script
//! a lent GPU will run cannot rot: every 3D catalog filter verified (exact
//! and linear fetches), the generated-vs-hand-written table, a render row per
//! filter, spliced into the file in place of an earlier GPU section.

use std::path::Path;
use std::process::Command;

fn script() -> std::path::PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../scripts/gpu-bench.sh")
}

fn three_d_filters() -> Vec<String> {
    boxforge::spec::catalog::names()
        .into_iter()
        .filter(|n| boxforge::spec::resolve(n).map(|s| s.dim() == 3).unwrap_or(false))
        .map(String::from)
        .collect()
}

#[test]
fn the_gpu_script_writes_its_section_in_its_small_size() {
    let dir = std::env::temp_dir().join(format!("boxforge-gpu-bench-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let out = dir.join("BENCHMARKS.md");
    std::fs::write(&out, "# Benchmarks\n\n## Before\n\nkept\n\n## GPU\n\nstale GPU rows\n\n## After\n\nkept too\n")
        .unwrap();
    let run = Command::new("bash")
        .arg(script())
        .args(["--small", "--out"])
        .arg(&out)
        .env("BOXFORGE_BIN", env!("CARGO_BIN_EXE_boxforge"))
        .output()
        .unwrap();
    let text = std::fs::read_to_string(&out).unwrap();
    let _ = std::fs::remove_dir_all(&dir);
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert!(run.status.success(), "{stderr}\n{text}");

    // Spliced: the other sections kept, the stale GPU section replaced, once.
    assert!(text.contains("## Before\n\nkept\n") && text.contains("## After\n\nkept too\n"), "{text}");
    assert!(!text.contains("stale GPU rows"), "{text}");
    assert_eq!(text.matches("\n## GPU\n").count(), 1, "{text}");
    let gpu = &text[text.find("\n## GPU\n").unwrap()..text.find("\n## After\n").unwrap()];
    assert!(gpu.contains("Adapter: llvmpipe") || gpu.contains("Adapter: "), "{gpu}");

    let filters = three_d_filters();
    assert!(filters.len() >= 8, "{filters:?}");
    for f in &filters {
        let verified: Vec<&str> =
            gpu.lines().filter(|l| l.starts_with(&format!("| {f} |")) && l.ends_with("| PASSED |")).collect();
        assert!(!verified.is_empty(), "no PASSED verify row for {f}:\n{gpu}");
        let rendered = gpu.lines().any(|l| {
            let cells: Vec<&str> = l.split('|').map(str::trim).collect();
            cells.len() == 5 && cells[1] == f && cells[2].parse::<f64>().is_ok_and(|ms| ms > 0.0)
        });
        assert!(rendered, "no render row with a time for {f}:\n{gpu}");
    }
    assert!(gpu.contains("| linear | "), "linear fetches judged:\n{gpu}");
    for r in boxforge_runtime::references::builtin() {
        assert!(gpu.contains(&format!("(`{}`)", r.entry)), "no row for the reference {}:\n{gpu}", r.name);
    }
}

#[test]
fn the_gpu_script_refuses_an_unknown_option_with_exit_2() {
    let run = Command::new("bash").arg(script()).arg("--fast").output().unwrap();
    assert_eq!(run.status.code(), Some(2));
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert!(stderr.contains("unknown option '--fast'") && stderr.contains("--small"), "{stderr}");
}
