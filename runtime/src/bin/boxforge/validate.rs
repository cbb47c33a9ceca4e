//! `boxforge validate`: naga validation and the branch-free proof of any
//! WGSL file; exit 0 when valid and branch-free, 1 otherwise.

use crate::common::Failure;

#[derive(clap::Args)]
pub struct ValidateArgs {
    file: std::path::PathBuf,
    /// Functions that must be branch-free (default: every function named
    /// *_eval or *_eval_grad).
    #[arg(long = "entry")]
    entries: Vec<String>,
    #[arg(long)]
    json: bool,
}

pub fn run(a: ValidateArgs) -> Result<(), Failure> {
    let ValidateArgs { file, entries, json } = a;
    let source = std::fs::read_to_string(&file)
        .map_err(|e| Failure(format!("cannot read {}: {e} (check the path)", file.display())))?;
    let report = boxforge::validate::validate_wgsl(&source, &file.display().to_string());
    let required: Vec<String> = if entries.is_empty() {
        report
            .functions
            .iter()
            .filter(|f| f.name.ends_with("_eval") || f.name.ends_with("_eval_grad"))
            .map(|f| f.name.clone())
            .collect()
    } else {
        entries
    };
    let names: Vec<&str> = required.iter().map(|s| s.as_str()).collect();
    let verdict =
        if report.valid { boxforge::validate::check_branch_free(&report, &names) } else { Err("invalid".into()) };
    if json {
        let v = serde_json::json!({
            "valid": report.valid,
            "error": report.error,
            "branch_free_required": required,
            "branch_free": verdict.is_ok(),
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
    }
    if verdict.is_ok() {
        Ok(())
    } else {
        std::process::exit(1)
    }
}
