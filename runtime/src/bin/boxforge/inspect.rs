//! `boxforge inspect`: derive filters and print their reports.

use crate::common::{derive_all, filter_names, Failure};
use boxforge::build::report::{Report, ReportOptions};
use boxforge::spec;

#[derive(clap::Args)]
pub struct InspectArgs {
    /// Catalog names or paths to .toml spec files.
    filters: Vec<String>,
    /// Every catalog filter.
    #[arg(long)]
    all: bool,
    /// Print JSON (one object, or an array with --all or several filters).
    #[arg(long)]
    json: bool,
    /// Include `derivation_seconds` in the JSON (left out by default so
    /// the same spec gives the same bytes; the text report always has it).
    #[arg(long, requires = "json")]
    timings: bool,
    /// List every piece's coefficients, however many (by default they stop
    /// past 4,096 polynomials and `work.coefficients_listed` is false).
    #[arg(long)]
    all_coefficients: bool,
}

pub fn run(a: InspectArgs) -> Result<(), Failure> {
    let InspectArgs { filters, all, json, timings, all_coefficients } = a;
    let options = ReportOptions { all_coefficients, ..ReportOptions::default() };
    let names = filter_names(filters, all)?;
    let resolved = names.iter().map(|n| spec::resolve(n)).collect::<Result<Vec<_>, _>>()?;
    let reports = derive_all(&resolved, |d, seconds| {
        let mut r = Report::with_options(&d, &options);
        r.derivation_seconds = (!json || timings).then_some(seconds);
        r
    })?;
    if json {
        if reports.len() == 1 && !all {
            outln!("{}", reports[0].to_json());
        } else {
            let parts: Vec<String> = reports.iter().map(|r| r.to_json()).collect();
            outln!("[\n{}\n]", parts.join(",\n"));
        }
    } else {
        for r in &reports {
            outln!("{}", r.to_text());
        }
    }
    Ok(())
}
