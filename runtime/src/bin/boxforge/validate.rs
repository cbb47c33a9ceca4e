//! `boxforge validate`: naga validation and the branch-free proof of any
//! WGSL file; with `--target`, its translations checked and compiled by the
//! compilers at hand (each named in the output); exit 0 when everything
//! holds, 1 otherwise.

use crate::common::{Failure, TargetArg};
use boxforge::back::compilers::{self, Outcome};
use boxforge::back::{self, Target};

#[derive(clap::Args)]
pub struct ValidateArgs {
    file: std::path::PathBuf,
    /// Functions that must be branch-free (default: every function named
    /// *_eval, *_eval_grad or *_eval_hessian).
    #[arg(long = "entry")]
    entries: Vec<String>,
    #[arg(long)]
    json: bool,
    /// Also translate the module (a boxforge module) into these targets,
    /// check each translation and compile it: glslang for GLSL, GLSL ES
    /// and HLSL (accepted by glslang), spirv-val for SPIR-V; MSL is emitted
    /// only (no Metal compiler on Linux). Repeat for several.
    #[arg(long = "target", value_enum)]
    targets: Vec<TargetArg>,
}

/// One translated file's outcome, as a line and as JSON.
fn compile_targets(
    source: &str,
    file: &std::path::Path,
    targets: &[Target],
) -> (bool, Vec<String>, Vec<serde_json::Value>) {
    let stem = file.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
    let stem = stem.strip_suffix(".wgsl").unwrap_or(&stem).to_string();
    let mut ok = true;
    let mut lines = Vec::new();
    let mut json = Vec::new();
    for &target in targets {
        let t = match back::translate(source, &stem, target, &Default::default()) {
            Ok(t) => t,
            Err(e) => {
                ok = false;
                lines.push(format!("  {:<8} refused: {e}", target.name()));
                json.push(serde_json::json!({"target": target.name(), "error": e.to_string()}));
                continue;
            }
        };
        for u in &t.units {
            let (verdict, by) = match compilers::compile(&t, u) {
                // glslang's HLSL front end is no D3D compiler: say no more than it accepted it.
                Outcome::Compiled { by } if target == Target::Hlsl => ("accepted".to_string(), by),
                Outcome::Compiled { by } => ("compiled".to_string(), by),
                Outcome::Failed { by, message } => {
                    ok = false;
                    (format!("FAILED: {}", message.lines().take(3).collect::<Vec<_>>().join(" | ")), by)
                }
                Outcome::Missing { tool, install } => {
                    ok = false;
                    (format!("not compiled: {tool} is not installed (install: {install})"), String::new())
                }
                Outcome::NotCompilable { why } => (format!("emitted, not compiled ({why})"), String::new()),
            };
            let by_text = if by.is_empty() { String::new() } else { format!(" by {by}") };
            lines.push(format!("  {:<8} {}: {verdict}{by_text}", target.name(), u.file_name));
            json.push(
                serde_json::json!({"target": target.name(), "file": u.file_name, "verdict": verdict, "compiler": by}),
            );
        }
    }
    (ok, lines, json)
}

pub fn run(a: ValidateArgs) -> Result<(), Failure> {
    let ValidateArgs { file, entries, json, targets } = a;
    let targets: Vec<Target> = targets.into_iter().map(Target::from).collect();
    let source = std::fs::read_to_string(&file)
        .map_err(|e| Failure(format!("cannot read {}: {e} (check the path)", file.display())))?;
    let report = boxforge::validate::validate_wgsl(&source, &file.display().to_string());
    let required: Vec<String> = if entries.is_empty() {
        report
            .functions
            .iter()
            .filter(|f| ["_eval", "_eval_grad", "_eval_hessian"].iter().any(|e| f.name.ends_with(e)))
            .map(|f| f.name.clone())
            .collect()
    } else {
        entries
    };
    let names: Vec<&str> = required.iter().map(|s| s.as_str()).collect();
    let verdict =
        if report.valid { boxforge::validate::check_branch_free(&report, &names) } else { Err("invalid".into()) };
    let (targets_ok, target_lines, target_json) =
        if report.valid { compile_targets(&source, &file, &targets) } else { (targets.is_empty(), vec![], vec![]) };
    let compilers_run: Vec<String> = [
        (
            targets.iter().any(|t| matches!(t, Target::Glsl | Target::GlslEs | Target::Hlsl)),
            compilers::glslang_version().map(|v| format!("glslangValidator {v}")),
        ),
        (targets.contains(&Target::Spirv), compilers::spirv_val_version().map(|v| format!("spirv-val {v}"))),
    ]
    .into_iter()
    .filter_map(|(used, c)| c.filter(|_| used && report.valid))
    .chain(std::iter::once("naga 30 (WGSL)".to_string()))
    .collect();
    if json {
        let v = serde_json::json!({
            "valid": report.valid,
            "error": report.error,
            "branch_free_required": required,
            "branch_free": verdict.is_ok(),
            "compilers": compilers_run,
            "targets": target_json,
            "functions": report.functions.iter().map(|f| serde_json::json!({
                "name": f.name,
                "branches": f.total_branches,
                "loops": f.total_loops,
                "kills": f.total_kills,
                "dynamic_array_indexing": f.total_dynamic_array_indexing,
                "loads": f.total_loads,
            })).collect::<Vec<_>>(),
        });
        outln!("{v}");
    } else {
        match &report.error {
            Some(e) => outln!("{} is not valid WGSL:\n{e}", file.display()),
            None => {
                outln!("{}: valid", file.display());
                for f in &report.functions {
                    outln!(
                        "  {:<32} branches {:>3}  loops {:>3}  kills {}  table lookups {:>3}  loads {:>4}{}",
                        f.name,
                        f.total_branches,
                        f.total_loops,
                        f.total_kills,
                        f.total_dynamic_array_indexing,
                        f.total_loads,
                        if required.contains(&f.name) { "  (must be branch-free)" } else { "" }
                    );
                }
            }
        }
        if let Err(e) = &verdict {
            if report.valid {
                outln!("FAILED: {e}");
            }
        }
        for l in &target_lines {
            outln!("{l}");
        }
        outln!("compilers run: {}", compilers_run.join(", "));
    }
    if verdict.is_ok() && targets_ok {
        Ok(())
    } else {
        std::process::exit(1)
    }
}
