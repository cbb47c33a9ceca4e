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
        Command::Inspect { filters, all, json } => {
            let names: Vec<String> = if all {
                if !filters.is_empty() {
                    return Err(Failure("give either --all or filter names, not both".into()));
                }
                spec::catalog::names().into_iter().map(String::from).collect()
            } else if filters.is_empty() {
                return Err(Failure(format!(
                    "name a filter (one of {}) or a spec file, or pass --all",
                    spec::catalog::names().join(", ")
                )));
            } else {
                filters
            };
            let resolved = names.iter().map(|n| spec::resolve(n)).collect::<Result<Vec<_>, _>>()?;
            let reports = derive_all(&resolved)?;
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

/// Derives filters in parallel (one thread per filter, bounded by the cores).
fn derive_all(filters: &[boxforge::Filter]) -> Result<Vec<Report>, Failure> {
    let threads = std::thread::available_parallelism().map(|n| n.get()).unwrap_or(1).max(1);
    let next = std::sync::atomic::AtomicUsize::new(0);
    let results: Vec<std::sync::Mutex<Option<Result<Report, Failure>>>> =
        filters.iter().map(|_| std::sync::Mutex::new(None)).collect();
    std::thread::scope(|scope| {
        for _ in 0..threads.min(filters.len()) {
            scope.spawn(|| loop {
                let i = next.fetch_add(1, std::sync::atomic::Ordering::SeqCst);
                if i >= filters.len() {
                    break;
                }
                let r = Derivation::new(&filters[i]).map(|d| Report::new(&d)).map_err(Failure::from);
                *results[i].lock().unwrap() = Some(r);
            });
        }
    });
    results.into_iter().map(|m| m.into_inner().unwrap().expect("every filter derived")).collect()
}
