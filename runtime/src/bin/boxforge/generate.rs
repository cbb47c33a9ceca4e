//! `boxforge generate`: derive filters and write their WGSL modules and
//! reports into a directory (or, with --check, compare with it).

use crate::common::{derive_all, filter_names, Failure, FetchArg, FormArg, LayoutArg, TargetArg, VariantArg};
use crate::request;
use boxforge::build::output::{self, ALL_LAYOUTS, ALL_VARIANTS};
use boxforge::emit::{EvalForm, FetchMode, Layout, Variant};
use boxforge::spec;

#[derive(clap::Args)]
pub struct GenerateArgs {
    /// Catalog names or paths to .toml spec files.
    filters: Vec<String>,
    /// Every catalog filter.
    #[arg(long)]
    all: bool,
    /// Output directory.
    #[arg(short, long)]
    out: std::path::PathBuf,
    /// Storage layout (default: both).
    #[arg(long, value_enum)]
    layout: Option<LayoutArg>,
    /// Code variant (default: both).
    #[arg(long, value_enum)]
    variant: Option<VariantArg>,
    /// Evaluation form for every filter (default: each spec's `form`, `auto`).
    #[arg(long, value_enum)]
    form: Option<FormArg>,
    /// Fetches in eval: exact loads, or hardware linear filtering (pairs
    /// of adjacent samples per fetch; fast variant only; packed layout for
    /// any filter, embedded for one-coset tensor products).
    #[arg(long, value_enum, default_value = "exact")]
    fetch: FetchArg,
    /// Shading language: WGSL (default; with the reports), or a translation
    /// of every module by naga's backends: SPIR-V binaries per kernel, GLSL
    /// 4.50 / GLSL ES 3.10, HLSL 5.1 or MSL 2.1, each a library to include
    /// plus the kernels as compute shaders (no reports).
    #[arg(long, value_enum, default_value = "wgsl")]
    target: TargetArg,
    /// Do not write: exit 1 if any file in the directory differs (stale).
    #[arg(long)]
    check: bool,
}

pub fn run(a: GenerateArgs) -> Result<(), Failure> {
    let GenerateArgs { filters, all, out, layout, variant, form, fetch, target, check } = a;
    let target = boxforge::back::Target::from(target);
    let layout = layout.map(Layout::from);
    let variant = variant.map(Variant::from);
    let form = form.map(EvalForm::from);
    let fetch = FetchMode::from(fetch);
    if !check {
        request::check_output_dir(&out, "--out")?;
    }
    let names = filter_names(filters.clone(), all)?;
    let mut resolved = names.iter().map(|n| spec::resolve(n)).collect::<Result<Vec<_>, _>>()?;
    if let Some(f) = form {
        resolved.iter_mut().for_each(|r| r.form = f);
    }
    let layouts: Vec<Layout> = match layout {
        Some(l) => vec![l],
        None => ALL_LAYOUTS.to_vec(),
    };
    let variants: Vec<Variant> = match variant {
        Some(v) => vec![v],
        // Linear fetches are a fast-variant feature.
        None if fetch == FetchMode::Linear => vec![Variant::Fast],
        None => ALL_VARIANTS.to_vec(),
    };
    let mut what = if all { "--all".to_string() } else { filters.join(" ") };
    if let Some(l) = layout {
        what.push_str(&format!(" --layout {}", l.name()));
    }
    if let Some(v) = variant {
        what.push_str(&format!(" --variant {}", v.name()));
    }
    if let Some(f) = form {
        what.push_str(&format!(" --form {}", f.name()));
    }
    if fetch == FetchMode::Linear {
        what.push_str(" --fetch linear");
    }
    if target != boxforge::back::Target::Wgsl {
        what.push_str(&format!(" --target {}", target.name()));
    }
    let command = format!("boxforge generate {what} -o {}", out.display());
    let started = std::time::Instant::now();
    let derivations = derive_all(&resolved, |d, t| (d, t))?;
    let mut stale = Vec::new();
    for (d, seconds) in &derivations {
        // Without --layout, linear fetches go where they apply: packed for
        // any lattice with 2Z^s, embedded for one-coset tensor products.
        let layouts: Vec<Layout> = if layout.is_none() && fetch == FetchMode::Linear {
            let mut l = Vec::new();
            if d.factorisation().is_some_and(|f| f.supports_linear_fetch()) {
                l.push(Layout::Embedded);
            }
            if boxforge::emit::coset_pivots(&d.filter.lattice).is_ok() {
                l.push(Layout::Packed);
            }
            l
        } else if layout.is_none() {
            output::default_layouts(d.facts.dim)
        } else {
            layouts.clone()
        };
        let files = output::translated_files(d, &command, &layouts, &variants, fetch, target)?;
        if check {
            for (name, bytes) in &files {
                if std::fs::read(out.join(name)).ok().as_deref() != Some(bytes.as_slice()) {
                    stale.push(out.join(name).display().to_string());
                }
            }
        } else {
            let written = output::write_byte_files(&out, &files)?;
            let list: Vec<String> = written.iter().map(|p| p.display().to_string()).collect();
            eprintln!("{:<16} derived in {seconds:.2} s: {}", d.filter.name, list.join(", "));
        }
    }
    if check && !stale.is_empty() {
        return Err(Failure(format!("stale generated files: {}; run `{command}` to refresh", stale.join(", "))));
    }
    eprintln!("{} filters in {:.2} s", derivations.len(), started.elapsed().as_secs_f64());
    Ok(())
}
