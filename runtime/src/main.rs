//! `boxforge`: derive, inspect (and later generate, verify, render, bench)
//! box-spline filters.

use boxforge::derive::Derivation;
use boxforge::report::Report;
use boxforge::spec;
use clap::{Parser, Subcommand};
use std::process::ExitCode;

#[derive(Parser)]
#[command(name = "boxforge", version, about = "Box-spline shader generator: exact derivations, branch-free WGSL")]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Derive a filter and print its report (knot planes, cells, reference
    /// pieces, stencils, BB coefficients, prefilter).
    Inspect {
        /// Catalog names or paths to .toml spec files.
        filters: Vec<String>,
        /// Every catalog filter.
        #[arg(long)]
        all: bool,
        /// Print JSON (one object, or an array with --all or several filters).
        #[arg(long)]
        json: bool,
    },
    /// Derive filters and write their reports (JSON + Markdown) into a directory.
    Generate {
        /// Catalog names or paths to .toml spec files.
        filters: Vec<String>,
        /// Every catalog filter.
        #[arg(long)]
        all: bool,
        /// Output directory.
        #[arg(short, long)]
        out: std::path::PathBuf,
        /// Do not write: exit 1 if any file in the directory differs (stale).
        #[arg(long)]
        check: bool,
    },
    /// List the built-in catalog.
    List,
}

/// A user-facing failure: one line on stderr, exit code 2.
struct Failure(String);

impl From<boxforge::Error> for Failure {
    fn from(e: boxforge::Error) -> Failure {
        Failure(e.to_string())
    }
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    match run(cli) {
        Ok(()) => ExitCode::SUCCESS,
        Err(Failure(msg)) => {
            eprintln!("error: {msg}");
            ExitCode::from(2)
        }
    }
}

fn run(cli: Cli) -> Result<(), Failure> {
    match cli.command {
        Command::List => {
            for name in spec::catalog::names() {
                let f = spec::catalog::get(name)?;
                println!("{:<16} {:<9} {}", f.name, f.lattice.name, f.description);
            }
            Ok(())
        }
        Command::Generate { filters, all, out, check } => {
            let names = filter_names(filters.clone(), all)?;
            let resolved = names.iter().map(|n| spec::resolve(n)).collect::<Result<Vec<_>, _>>()?;
            let what = if all { "--all".to_string() } else { filters.join(" ") };
            let command = format!("boxforge generate {what} -o {}", out.display());
            let started = std::time::Instant::now();
            let derivations = derive_all(&resolved, |d| d)?;
            let mut stale = Vec::new();
            for d in &derivations {
                let files = boxforge::output::report_files(d, &command);
                if check {
                    for (name, text) in &files {
                        if std::fs::read_to_string(out.join(name)).ok().as_deref() != Some(text.as_str()) {
                            stale.push(out.join(name).display().to_string());
                        }
                    }
                } else {
                    let written = boxforge::output::write_files(&out, &files)?;
                    let list: Vec<String> = written.iter().map(|p| p.display().to_string()).collect();
                    eprintln!("{:<16} {}", d.filter.name, list.join(", "));
                }
            }
            if check && !stale.is_empty() {
                return Err(Failure(format!(
                    "stale generated files: {}; run `{command}` to refresh",
                    stale.join(", ")
                )));
            }
            eprintln!("{} filters in {:.2} s", derivations.len(), started.elapsed().as_secs_f64());
            Ok(())
        }
        Command::Inspect { filters, all, json } => {
            let names = filter_names(filters, all)?;
            let resolved = names.iter().map(|n| spec::resolve(n)).collect::<Result<Vec<_>, _>>()?;
            let reports = derive_all(&resolved, |d| Report::new(&d))?;
            if json {
                if reports.len() == 1 && !all {
                    println!("{}", reports[0].to_json());
                } else {
                    let parts: Vec<String> = reports.iter().map(|r| r.to_json()).collect();
                    println!("[\n{}\n]", parts.join(",\n"));
                }
            } else {
                for r in &reports {
                    println!("{}", r.to_text());
                }
            }
            Ok(())
        }
    }
}

/// The filters named on the command line, or the catalog with --all.
fn filter_names(filters: Vec<String>, all: bool) -> Result<Vec<String>, Failure> {
    if all {
        if !filters.is_empty() {
            return Err(Failure("give either --all or filter names, not both".into()));
        }
        Ok(spec::catalog::names().into_iter().map(String::from).collect())
    } else if filters.is_empty() {
        Err(Failure(format!(
            "name a filter (one of {}) or a spec file, or pass --all",
            spec::catalog::names().join(", ")
        )))
    } else {
        Ok(filters)
    }
}

/// Derives filters in parallel (a worker per core), mapping each result.
fn derive_all<T: Send>(filters: &[boxforge::Filter], map: impl Fn(Derivation) -> T + Sync) -> Result<Vec<T>, Failure> {
    let threads = std::thread::available_parallelism().map(|n| n.get()).unwrap_or(1).max(1);
    let next = std::sync::atomic::AtomicUsize::new(0);
    let results: Vec<std::sync::Mutex<Option<Result<T, Failure>>>> =
        filters.iter().map(|_| std::sync::Mutex::new(None)).collect();
    std::thread::scope(|scope| {
        for _ in 0..threads.min(filters.len()) {
            scope.spawn(|| loop {
                let i = next.fetch_add(1, std::sync::atomic::Ordering::SeqCst);
                if i >= filters.len() {
                    break;
                }
                let r = Derivation::new(&filters[i]).map(&map).map_err(Failure::from);
                *results[i].lock().unwrap() = Some(r);
            });
        }
    });
    results.into_iter().map(|m| m.into_inner().unwrap().expect("every filter derived")).collect()
}
