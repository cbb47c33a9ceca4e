//! Writing generated files: atomically (temp file + rename), with a header
//! naming the command that made them, deterministically.

use crate::build::report::{module_bindings, Report, ShaderReport};
use crate::derive::Derivation;
use crate::emit::{emit, EmitOptions, FetchMode, Layout, Variant};
use crate::error::{Error, Result};
use std::path::{Path, PathBuf};

/// Writes `bytes` to `path` via a temporary file in the same directory and a
/// rename, so readers never see a half-written file.
///
/// # Errors
///
/// [`Error::Io`] (naming the directory, temporary file or target) when creating
/// the directory, writing or renaming fails.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<()> {
    let dir = path.parent().filter(|p| !p.as_os_str().is_empty()).unwrap_or(Path::new("."));
    std::fs::create_dir_all(dir).map_err(|source| Error::Io { path: dir.to_path_buf(), source })?;
    let name = path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
    let tmp = dir.join(format!(".{name}.tmp{}", std::process::id()));
    std::fs::write(&tmp, bytes).map_err(|source| Error::Io { path: tmp.clone(), source })?;
    std::fs::rename(&tmp, path).map_err(|source| Error::Io { path: path.to_path_buf(), source })
}

/// The files generated for one filter: the WGSL modules for every requested
/// (layout, variant), then the JSON and Markdown reports (with the shaders'
/// counts): (file name, contents).
///
/// # Errors
///
/// Every error of [`emit`] ([`Error::EmitCap`], [`Error::Spec`]).
pub fn generated_files(
    d: &Derivation,
    command: &str,
    layouts: &[Layout],
    variants: &[Variant],
) -> Result<Vec<(String, String)>> {
    generated_files_with(d, command, layouts, variants, FetchMode::Exact)
}

/// [`generated_files`] with a fetch mode for every module
/// (`FetchMode::Linear` writes `<filter>.<layout>.linear.wgsl`).
///
/// # Errors
///
/// As [`generated_files`], [`Error::Unsupported`] when an emitted module does
/// not validate, and [`Error::Spec`] where linear fetches do not
/// apply (the naive variant; the embedded layout of a filter that is not a
/// one-coset tensor product).
pub fn generated_files_with(
    d: &Derivation,
    command: &str,
    layouts: &[Layout],
    variants: &[Variant],
    fetch: FetchMode,
) -> Result<Vec<(String, String)>> {
    let mut files = Vec::new();
    let mut stats = Vec::new();
    for &layout in layouts {
        for &variant in variants {
            let opts = EmitOptions { layout, variant, command: command.to_string(), fetch, ..EmitOptions::default() };
            let e = emit(d, &opts)?;
            let bindings = module_bindings(&d.filter.name, &e.file_name, &e.source)?;
            stats.push(ShaderReport { stats: e.stats, bindings });
            files.push((e.file_name, e.source));
        }
    }
    files.extend(report_files_with(d, command, stats));
    Ok(files)
}

/// The files of [`generated_files_with`] in another language: every module
/// translated into `target` ([`crate::back::translate`], checked), without
/// the WGSL and without the reports (which `generate` without `--target`
/// writes): (file name, bytes). WGSL gives [`generated_files_with`]'s files.
///
/// # Errors
///
/// As [`generated_files_with`], and [`Error::Translate`] when a backend
/// refuses a module or its check fails.
pub fn translated_files(
    d: &Derivation,
    command: &str,
    layouts: &[Layout],
    variants: &[Variant],
    fetch: FetchMode,
    target: crate::back::Target,
) -> Result<Vec<(String, Vec<u8>)>> {
    if target == crate::back::Target::Wgsl {
        let files = generated_files_with(d, command, layouts, variants, fetch)?;
        return Ok(files.into_iter().map(|(n, t)| (n, t.into_bytes())).collect());
    }
    let mut files = Vec::new();
    for &layout in layouts {
        for &variant in variants {
            let opts = EmitOptions { layout, variant, command: command.to_string(), fetch, ..EmitOptions::default() };
            let e = emit(d, &opts)?;
            let stem = e.file_name.strip_suffix(".wgsl").unwrap_or(&e.file_name);
            let t = crate::back::translate(&e.source, stem, target, &crate::back::TranslateOptions::default())?;
            files.extend(t.units.into_iter().map(|u| (u.file_name, u.code.bytes())));
        }
    }
    Ok(files)
}

/// Every layout and variant.
pub const ALL_LAYOUTS: [Layout; 4] = [Layout::Embedded, Layout::Packed, Layout::Bricked, Layout::BrickedPacked];
/// The layouts `generate` writes for a filter of dimension `dim` unless told
/// otherwise: all four up to 3D; embedded and packed in 4D (4D samples are a
/// storage buffer, which the bricked layouts' texture pool and page table are not).
pub fn default_layouts(dim: usize) -> Vec<Layout> {
    ALL_LAYOUTS.into_iter().filter(|l| dim <= 3 || !l.is_bricked()).collect()
}
/// Both code shapes, for generating every file.
pub const ALL_VARIANTS: [Variant; 2] = [Variant::Fast, Variant::Naive];

/// The reports alone (no shaders).
pub fn report_files(d: &Derivation, command: &str) -> Vec<(String, String)> {
    report_files_with(d, command, vec![])
}

fn report_files_with(d: &Derivation, command: &str, shaders: Vec<ShaderReport>) -> Vec<(String, String)> {
    let mut report = Report::new(d);
    report.shaders = shaders;
    let name = &d.filter.name;
    let mut json = report.to_json_with_header(command);
    json.push('\n');
    let md = format!("<!-- generated by `{command}`; do not edit -->\n\n{}", report.to_markdown());
    vec![(format!("{name}.json"), json), (format!("{name}.md"), md)]
}

/// [`write_files`] for contents that may be binary (SPIR-V).
///
/// # Errors
///
/// [`Error::Io`] from [`write_atomic`]; files before the failing one stay written.
pub fn write_byte_files(dir: &Path, files: &[(String, Vec<u8>)]) -> Result<Vec<PathBuf>> {
    files
        .iter()
        .map(|(name, bytes)| {
            let p = dir.join(name);
            write_atomic(&p, bytes)?;
            Ok(p)
        })
        .collect()
}

/// Writes every file of `files` into `dir`; returns the paths written.
///
/// # Errors
///
/// [`Error::Io`] from [`write_atomic`]; files before the failing one stay written.
pub fn write_files(dir: &Path, files: &[(String, String)]) -> Result<Vec<PathBuf>> {
    files
        .iter()
        .map(|(name, text)| {
            let p = dir.join(name);
            write_atomic(&p, text.as_bytes())?;
            Ok(p)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::build::report::REPORT_SCHEMA_VERSION;
    use crate::spec::catalog;

    // The report's JSON as generate writes it (tested here, where the
    // shaders' bindings are added, so that report.rs does not import output.rs).

    /// The JSON layout that [`REPORT_SCHEMA_VERSION`] stands for: the
    /// top-level keys, the keys of a `shaders` entry and of a binding. A
    /// change of layout must change the version too, and then this pin.
    const PINNED: (u32, &[&str], &[&str], &[&str]) = (
        3,
        &[
            "generated_by",
            "schema_version",
            "name",
            "description",
            "dimension",
            "lattice",
            "lattice_generators",
            "lattice_det",
            "directions",
            "degree",
            "approximation_order",
            "continuity",
            "support_volume",
            "knot_planes",
            "grid_offset",
            "cube_classes",
            "cube_class_corners",
            "cells_per_fundamental_domain",
            "polynomial_pieces_per_fundamental_domain",
            "symmetry_order",
            "reference_pieces",
            "max_stencil_size",
            "prefilter",
            "prefilter_shells",
            "cells",
            "evaluation",
            "shaders",
            "linear_fetch",
            "linear_fetch_packed",
            "work",
        ],
        &[
            "layout",
            "variant",
            "locate",
            "candidates",
            "fetches_per_eval",
            "vector_adds",
            "matvec_adds",
            "ops_eval",
            "ops_eval_grad",
            "ops_eval_hessian",
            "hessian_form",
            "form",
            "forms",
            "bounds",
            "fetch",
            "bindings",
        ],
        &["group", "binding", "name", "kind", "format", "entry_points", "functions", "purpose"],
    );

    fn zp_report() -> serde_json::Value {
        let d = Derivation::new(&catalog::get("zp").unwrap()).unwrap();
        let files = generated_files(&d, "test", &ALL_LAYOUTS, &ALL_VARIANTS).unwrap();
        let json = &files.iter().find(|(n, _)| n == "zp.json").expect("the JSON report is generated").1;
        serde_json::from_str(json).unwrap()
    }

    /// The keys of a JSON object, sorted (the layout is the set of keys).
    fn keys(v: &serde_json::Value) -> Vec<&str> {
        let mut k: Vec<&str> = v.as_object().expect("an object").keys().map(String::as_str).collect();
        k.sort_unstable();
        k
    }

    fn sorted(k: &[&'static str]) -> Vec<&'static str> {
        let mut k = k.to_vec();
        k.sort_unstable();
        k
    }

    #[test]
    fn json_layout_is_the_one_its_schema_version_names() {
        let v = zp_report();
        let shader = &v["shaders"][0];
        let found = (
            v["schema_version"].as_u64().expect("schema_version is a number") as u32,
            keys(&v),
            keys(shader),
            keys(&shader["bindings"][0]),
        );
        assert_eq!(REPORT_SCHEMA_VERSION, PINNED.0, "the pin is of the current version");
        assert_eq!(
            found,
            (PINNED.0, sorted(PINNED.1), sorted(PINNED.2), sorted(PINNED.3)),
            "the report's JSON layout changed: raise REPORT_SCHEMA_VERSION and update PINNED"
        );
    }

    #[test]
    fn bindings_of_each_module_are_read_from_its_wgsl() {
        let v = zp_report();
        let rows = |layout: &str, variant: &str| -> Vec<String> {
            let shader = v["shaders"]
                .as_array()
                .unwrap()
                .iter()
                .find(|s| s["layout"] == layout && s["variant"] == variant)
                .expect("every layout and variant is reported");
            shader["bindings"]
                .as_array()
                .unwrap()
                .iter()
                .map(|b| {
                    format!(
                        "{}/{} {} {} {} ep={} fn={} purpose={}",
                        b["group"],
                        b["binding"],
                        b["name"].as_str().unwrap(),
                        b["kind"].as_str().unwrap(),
                        b["format"].as_str().unwrap_or("-"),
                        b["entry_points"].as_array().unwrap().len(),
                        b["functions"]
                            .as_array()
                            .unwrap()
                            .iter()
                            .map(|f| f.as_str().unwrap())
                            .collect::<Vec<_>>()
                            .join(","),
                        b["purpose"].is_string()
                    )
                })
                .collect()
        };
        // The sample bindings come first, then the kernels' (out, job); every
        // known name has its purpose; eval, eval_grad and the fetch are
        // helpers of nothing else only where no other function calls them.
        let embedded = rows("embedded", "fast");
        assert_eq!(embedded.len(), 3, "{embedded:#?}");
        assert!(embedded[0].starts_with("0/0 zp_volume texture_2d<f32> - ep=2 fn="), "{embedded:#?}");
        assert!(embedded[0].contains("zp_eval,zp_eval_grad") && embedded[0].ends_with("purpose=true"));
        assert_eq!(embedded[1], "0/1 zp_out storage buffer read_write array<f32> ep=2 fn= purpose=true");
        assert_eq!(embedded[2], "0/2 zp_job uniform buffer zp_Job ep=2 fn= purpose=true");
        let packed = rows("packed", "naive");
        assert_eq!(packed.len(), 4, "{packed:#?}");
        assert!(packed[0].starts_with("0/0 zp_cosets texture_2d<f32> - ep=2 fn="), "{packed:#?}");
        assert!(packed[1].starts_with("0/1 zp_grid uniform buffer zp_Grid ep=2 fn="), "{packed:#?}");
        assert_eq!(packed[2], "0/2 zp_out storage buffer read_write array<f32> ep=2 fn= purpose=true");
        assert_eq!(packed[3], "0/3 zp_job uniform buffer zp_Job ep=2 fn= purpose=true");
    }

    #[test]
    fn atomic_write_replaces_and_leaves_no_temp_files() {
        let dir = std::env::temp_dir().join(format!("boxforge-out-{}", std::process::id()));
        let p = dir.join("a.txt");
        write_atomic(&p, b"one").unwrap();
        write_atomic(&p, b"two").unwrap();
        assert_eq!(std::fs::read(&p).unwrap(), b"two");
        let names: Vec<_> = std::fs::read_dir(&dir).unwrap().map(|e| e.unwrap().file_name()).collect();
        assert_eq!(names.len(), 1);
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
