//! `boxforge`: derive, inspect, generate, validate, verify, render and
//! bench box-spline filters; the demo and the browser viewer.

#[macro_use]
mod common;
mod bench;
mod bench_pyramid;
mod choices;
mod convert;
mod demo;
mod generate;
mod inspect;
mod list;
mod render;
mod request;
mod validate;
mod verify;
mod web;

use clap::{Parser, Subcommand};
use common::Failure;
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
    Inspect(inspect::InspectArgs),
    /// Derive filters and write their WGSL modules and reports (JSON +
    /// Markdown) into a directory.
    Generate(generate::GenerateArgs),
    /// Validate any WGSL file with naga and prove functions branch-free and
    /// table-free (no if/switch/loop/discard, no dynamically indexed arrays).
    Validate(validate::ValidateArgs),
    /// Evaluate a filter's eval / eval_grad / eval_hessian on the GPU at random points of a
    /// random volume and compare with the exact evaluator (f64).
    Verify(verify::VerifyArgs),
    /// Render an isosurface (or, with --mode dvr, a direct volume rendering) to PNG on the GPU.
    Render(render::RenderArgs),
    /// The main job: generate the catalog, render Marschner-Lobb and the MNI
    /// head with bcc7, bcc8, fcc6 and cc_tricubic into out/, print a table.
    Demo(DemoArgs),
    /// Benchmarks: evaluation throughput per filter x layout x variant with
    /// ratios, rendering, gradients, quality. Writes docs/BENCHMARKS.md with --markdown.
    Bench(bench::BenchArgs),
    /// Write the browser viewer: a static site (HTML, one ES module, the
    /// generated WGSL, catalog.json, the MNI head as .bfv) that ray casts
    /// the catalog's filters in WebGPU with the same shaders as `render`.
    /// With --serve, serve it on 127.0.0.1 and print the URL.
    Web(web::WebArgs),
    /// Write a volume (NIfTI, raw, OME-Zarr, ml:N) as an OME-Zarr 0.5 pyramid, streaming.
    Convert(convert::ConvertArgs),
    /// List the built-in catalog.
    List,
}

// `boxforge demo` (the run itself is in demo.rs).
#[derive(clap::Args)]
struct DemoArgs {
    #[arg(long, default_value = "out")]
    out: std::path::PathBuf,
    #[arg(long, default_value_t = 256)]
    size: u32,
    #[arg(long)]
    adapter: Option<String>,
}

fn main() -> ExitCode {
    let cli = match Cli::try_parse() {
        Ok(cli) => cli,
        Err(e) => {
            use clap::error::ErrorKind;
            if matches!(
                e.kind(),
                ErrorKind::DisplayHelp
                    | ErrorKind::DisplayVersion
                    | ErrorKind::DisplayHelpOnMissingArgumentOrSubcommand
            ) {
                e.exit(); // help text, with clap's exit code
            }
            // One line, like every other failure: clap's first line, and where to look.
            let text = e.render().to_string();
            let message: Vec<&str> = text
                .lines()
                .map(str::trim)
                .skip_while(|l| l.is_empty())
                .take_while(|l| !l.is_empty() && !l.starts_with("Usage:"))
                .collect();
            let message = message.join(" ");
            let message = message.strip_prefix("error: ").unwrap_or(&message);
            eprintln!("error: {message} (see boxforge --help)");
            return ExitCode::from(2);
        }
    };
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
        Command::Inspect(a) => inspect::run(a),
        Command::Generate(a) => generate::run(a),
        Command::Validate(a) => validate::run(a),
        Command::Verify(a) => verify::run(a),
        Command::Render(a) => render::run(a),
        Command::Demo(DemoArgs { out, size, adapter }) => {
            crate::request::check_image_edge(size)?;
            crate::request::check_output_dir(&out, "--out")?;
            Ok(demo::run(&out, size, adapter.as_deref())?)
        }
        Command::Bench(a) => bench::run(a),
        Command::Web(a) => web::run(a),
        Command::Convert(a) => convert::run(a),
        Command::List => list::run(),
    }
}
