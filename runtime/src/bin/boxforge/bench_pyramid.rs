//! `boxforge bench --pyramid`: the quality of pyramid levels per reduction
//! (`bench::levels`), CPU only.

use crate::common::{Failure, Section};
use boxforge_runtime::bench;
use boxforge_runtime::progress;
use std::path::Path;

/// Measures `filters` (default: trilinear and tricubic on CC) and writes the section.
pub fn run(filters: &[String], smoke: bool, markdown: Option<&Path>, json: bool) -> Result<(), Failure> {
    let names: Vec<String> =
        if filters.is_empty() { vec!["cc_trilinear".into(), "cc_tricubic".into()] } else { filters.to_vec() };
    let (edge, levels, points) = if smoke { (24, 2, 200) } else { (129, 4, 20000) };
    let mut flags = format!("--pyramid{}", if smoke { " --smoke" } else { "" });
    if !filters.is_empty() {
        flags.push_str(&format!(" --filters {}", filters.join(",")));
    }
    let section = Section::new("pyramid", &flags, markdown)?;
    let mut derivations = Vec::new();
    for name in &names {
        let f = boxforge::spec::resolve(name)?;
        if f.lattice.name != "cc" || f.dim() != 3 {
            return Err(Failure(format!(
                "--pyramid measures Cartesian pyramids: {name} is on {} ({}D); give 3D filters on cc (cc_trilinear, cc_tricubic, ...)",
                f.lattice.name,
                f.dim()
            )));
        }
        derivations.push(boxforge::derive::Derivation::new(&f)?);
    }
    let scratch = std::env::temp_dir().join(format!("boxforge-bench-pyramid-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&scratch);
    std::fs::create_dir_all(&scratch).map_err(|e| Failure(format!("cannot make {}: {e}", scratch.display())))?;
    let steps = progress::Steps::new();
    let report = bench::levels::measure(&derivations, edge, levels, points, &scratch, &|m: &str| steps.step(m));
    steps.finish();
    let _ = std::fs::remove_dir_all(&scratch);
    let report = report.map_err(|e| Failure(e.to_string()))?;
    let text = bench::levels::markdown(&report, section.command());
    section.finish(&report, &text, bench::levels::splice, json)
}
