//! `boxforge`: derive, inspect (and later generate, verify, render, bench)
//! box-spline filters.

use boxforge::build::output::{ALL_LAYOUTS, ALL_VARIANTS};
use boxforge::build::report::Report;
use boxforge::derive::Derivation;
use boxforge::emit::{Layout, Variant};
use boxforge::spec;
use boxforge_runtime::gpu::Gpu;
use boxforge_runtime::progress;
use boxforge_runtime::render::iso::{self as render, RenderOptions};
use boxforge_runtime::request;
use boxforge_runtime::scene::{self, Conversion};

/// `println!` that ends the process quietly when stdout is closed (e.g.
/// `boxforge inspect --all | head`) instead of panicking on a broken pipe.
macro_rules! outln {
    ($($arg:tt)*) => {{
        use std::io::Write as _;
        let mut out = std::io::stdout().lock();
        if let Err(e) = writeln!(out, $($arg)*) {
            if e.kind() == std::io::ErrorKind::BrokenPipe {
                std::process::exit(0);
            }
            eprintln!("error: cannot write to stdout: {e}");
            std::process::exit(2);
        }
    }};
}

mod demo;
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
        /// Include `derivation_seconds` in the JSON (left out by default so
        /// the same spec gives the same bytes; the text report always has it).
        #[arg(long, requires = "json")]
        timings: bool,
    },
    /// Derive filters and write their WGSL modules and reports (JSON +
    /// Markdown) into a directory.
    Generate {
        /// Catalog names or paths to .toml spec files.
        filters: Vec<String>,
        /// Every catalog filter.
        #[arg(long)]
        all: bool,
        /// Output directory.
        #[arg(short, long)]
        out: std::path::PathBuf,
        /// Storage layout (default: both).
        #[arg(long, value_parser = ["embedded", "packed"])]
        layout: Option<String>,
        /// Code variant (default: both).
        #[arg(long, value_parser = ["fast", "naive"])]
        variant: Option<String>,
        /// Evaluation form for every filter (default: each spec's `form`, `auto`).
        #[arg(long, value_parser = ["auto", "factored", "power", "ridge", "bb", "dense"])]
        form: Option<String>,
        /// Fetches in eval: exact loads, or hardware linear filtering (pairs
        /// of adjacent samples per fetch; fast variant only; packed layout for
        /// any filter, embedded for one-coset tensor products).
        #[arg(long, value_parser = ["exact", "linear"], default_value = "exact")]
        fetch: String,
        /// Do not write: exit 1 if any file in the directory differs (stale).
        #[arg(long)]
        check: bool,
    },
    /// Validate any WGSL file with naga and prove functions branch-free and
    /// table-free (no if/switch/loop/discard, no dynamically indexed arrays).
    Validate {
        file: std::path::PathBuf,
        /// Functions that must be branch-free (default: every function named
        /// *_eval or *_eval_grad).
        #[arg(long = "entry")]
        entries: Vec<String>,
        #[arg(long)]
        json: bool,
    },
    /// Evaluate a filter's eval / eval_grad on the GPU at random points of a
    /// random volume and compare with the exact evaluator (f64).
    Verify {
        /// Catalog name or spec file (3D filters).
        #[arg(long)]
        filter: String,
        #[arg(long, value_parser = ["embedded", "packed"], default_value = "embedded")]
        layout: String,
        #[arg(long, value_parser = ["fast", "naive"], default_value = "fast")]
        variant: String,
        /// Evaluation form (default: the filter's own, `auto`: the cheapest).
        #[arg(long, value_parser = ["auto", "factored", "power", "ridge", "bb", "dense"])]
        form: Option<String>,
        /// Fetch bounds: clamp to the volume, or unchecked (caller pads).
        #[arg(long, value_parser = ["clamp", "unchecked"], default_value = "clamp")]
        bounds: String,
        /// Fetches in eval: exact texel loads, or hardware linear filtering
        /// (tensor-product filters on the cc lattice, embedded layout).
        #[arg(long, value_parser = ["exact", "linear"], default_value = "exact")]
        fetch: String,
        #[arg(long, default_value_t = 100_000)]
        points: usize,
        #[arg(long, default_value_t = 1)]
        seed: u64,
        /// Adapter name (substring); default: WGPU_ADAPTER_NAME or the best available.
        #[arg(long)]
        adapter: Option<String>,
        #[arg(long)]
        json: bool,
    },
    /// Render an isosurface (or, with --mode dvr, a direct volume rendering) to PNG on the GPU.
    Render {
        /// iso: isosurface; dvr: emission-absorption volume rendering with --tf.
        #[arg(long, value_parser = ["iso", "dvr"], default_value = "iso")]
        mode: String,
        /// Transfer function for --mode dvr: a preset (mni-tissue, mni-opaque, marschner-lobb) or a JSON file.
        #[arg(long)]
        tf: Option<String>,
        /// --mode dvr: point-sample the transfer function (opacity-corrected) instead of pre-integrating.
        #[arg(long)]
        no_preintegration: bool,
        /// --mode dvr: none, or perm (precompute density and gradient at quantized positions of the cells
        /// the transfer function shows, and look them up; Lim and Shin's PERM).
        #[arg(long, default_value = "none")]
        cache: String,
        /// --mode dvr: raycast, or pt (projected tetrahedra, Mattausch et al.: the Delaunay tetrahedra of
        /// BCC or the Kuhn tetrahedra of CC cubes rasterised back to front, barycentric interpolation,
        /// orthographic; the filter sets the lattice and the clipped box).
        #[arg(long, value_parser = ["raycast", "pt"], default_value = "raycast")]
        renderer: String,
        /// --renderer pt: gouraud (lighting at the vertices) or phong (per fragment), with smooth vertex normals.
        #[arg(long, value_parser = ["gouraud", "phong"], default_value = "phong")]
        shading: String,
        /// --cache perm: density positions per cell axis (N^3 per cell; default 5).
        #[arg(long)]
        qc: Option<u32>,
        /// --cache perm: gradient positions per cell axis (M^3 per cell; default --qc).
        #[arg(long)]
        qc_grad: Option<u32>,
        /// --cache perm: opaque-boundary peeling (drop the cached cells no ray reaches before it
        /// terminates; the image is unchanged for views from outside the volume).
        #[arg(long)]
        peel: bool,
        #[arg(long)]
        filter: String,
        /// `ml:N` (Marschner-Lobb, about N^3 samples), a .nii/.nii.gz file, or a raw file with --raw.
        #[arg(long)]
        volume: String,
        /// Raw volume format: nx,ny,nz,type (type u8, u16 or f32).
        #[arg(long)]
        raw: Option<String>,
        /// Data lattice (default: the filter's).
        #[arg(long)]
        lattice: Option<String>,
        /// Lattice subset of a Cartesian volume (default).
        #[arg(long, conflicts_with = "resample")]
        subset: bool,
        /// Resample a Cartesian volume on the lattice at a matched sample count.
        #[arg(long)]
        resample: bool,
        #[arg(long, default_value_t = 0.5, allow_negative_numbers = true)]
        iso: f32,
        #[arg(long, default_value_t = 512)]
        size: u32,
        /// Azimuth,elevation in degrees.
        #[arg(long, default_value = "30,25", allow_hyphen_values = true)]
        view: String,
        #[arg(long)]
        perspective: bool,
        /// Turn empty-space skipping off.
        #[arg(long)]
        no_skip: bool,
        /// Ray step in cells.
        #[arg(long, default_value_t = 0.25, allow_negative_numbers = true)]
        step: f32,
        /// First hit: exact (ray cut at knot planes, Bernstein root isolation: no thin
        /// feature missed) or fixed steps of --step (default: the faster one on lavapipe).
        #[arg(long, value_parser = ["exact", "step"], default_value = "step")]
        hit: String,
        #[arg(long, value_parser = ["embedded", "packed"], default_value = "embedded")]
        layout: String,
        #[arg(long)]
        adapter: Option<String>,
        #[arg(long, default_value = "out.png")]
        out: std::path::PathBuf,
    },
    /// The main job: generate the catalog, render Marschner-Lobb and the MNI
    /// head with bcc7, bcc8, fcc6 and cc_tricubic into out/, print a table.
    Demo {
        #[arg(long, default_value = "out")]
        out: std::path::PathBuf,
        #[arg(long, default_value_t = 256)]
        size: u32,
        #[arg(long)]
        adapter: Option<String>,
    },
    /// Benchmarks: evaluation throughput per filter x layout x variant with
    /// ratios, rendering, gradients, quality. Writes docs/BENCHMARKS.md with --markdown.
    Bench {
        /// Comma-separated filters (default: the 3D catalog filters).
        #[arg(long, value_delimiter = ',')]
        filters: Vec<String>,
        /// A seconds-long smoke run (numbers not meaningful).
        #[arg(long)]
        smoke: bool,
        /// Skip the naive variant (its shaders compile slowly on lavapipe).
        #[arg(long)]
        no_naive: bool,
        /// Skip the quality section.
        #[arg(long)]
        no_quality: bool,
        /// Measure Lim and Shin's PERM cache instead (DVR with the cache vs
        /// direct evaluation for bcc_linear, bcc7, bcc12, cc_tricubic at
        /// N = 3, 5, 10 and (5, 3)): with --markdown, replaces only its
        /// section of the file.
        #[arg(long, conflicts_with_all = ["derive", "literature"])]
        perm: bool,
        /// Time the derivation of a fixed, seeded set of random specs instead
        /// (no GPU): with --markdown, replaces only its section of the file.
        #[arg(long)]
        derive: bool,
        /// How many seeded random specs --derive uses (default 105).
        #[arg(long, requires = "derive")]
        specs: Option<usize>,
        /// Measure the reconstructions and renderers of the source papers
        /// instead (Mattausch et al.'s BCC schemes, projected tetrahedra on BCC
        /// and CC, and ours), with each paper's claim and whether it holds here:
        /// with --markdown, replaces only its section of the file.
        #[arg(long, conflicts_with = "derive")]
        literature: bool,
        /// Skip the hand-written references (generated vs hand-written).
        #[arg(long)]
        no_references: bool,
        /// Interleaved timing rounds per comparison (default: 7, or 3 with --smoke).
        #[arg(long)]
        runs: Option<usize>,
        #[arg(long)]
        json: bool,
        /// Write the report as Markdown (e.g. docs/BENCHMARKS.md).
        #[arg(long)]
        markdown: Option<std::path::PathBuf>,
        /// A WGSL file with an evaluation function `fn NAME(p: vec3<f32>) -> f32`
        /// to time beside the generated module of --like (it is appended to
        /// that module, so it can use its bindings and `<filter>_fetch`).
        #[arg(long, requires_all = ["entry", "like"])]
        wgsl: Option<String>,
        #[arg(long)]
        entry: Option<String>,
        #[arg(long)]
        like: Option<String>,
        #[arg(long)]
        adapter: Option<String>,
    },
    /// Write the browser viewer: a static site (HTML, one ES module, the
    /// generated WGSL, catalog.json, the MNI head as .bfv) that ray casts
    /// the catalog's filters in WebGPU with the same shaders as `render`.
    /// With --serve, serve it on 127.0.0.1 and print the URL.
    Web {
        /// Spec files (or catalog names) to add; the whole catalog is always in.
        specs: Vec<String>,
        /// Only these filters (comma-separated catalog names or spec files) instead of the catalog.
        #[arg(long, value_delimiter = ',')]
        only: Vec<String>,
        /// Site folder (default: site). --serve builds it only when it holds no site yet.
        #[arg(short, long)]
        out: Option<std::path::PathBuf>,
        /// Serve the site on 127.0.0.1 and print its URL (until interrupted).
        #[arg(long)]
        serve: bool,
        /// Port for --serve (0: any free port).
        #[arg(long, default_value_t = 8000, requires = "serve")]
        port: u16,
        /// Leave the MNI head out of the site (it is 3.6 MB).
        #[arg(long)]
        no_mni: bool,
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
        Command::Web { specs, only, out, serve, port, no_mni } => {
            let dir = out.clone().unwrap_or_else(|| std::path::PathBuf::from("site"));
            // --serve serves an existing site as it is (build it again without --serve).
            let build = !serve || !dir.join("index.html").is_file();
            if build {
                request::check_output_dir(&dir, "--out").map_err(Failure)?;
                let mut names: Vec<String> = if only.is_empty() {
                    spec::catalog::names().into_iter().map(String::from).collect()
                } else {
                    only.clone()
                };
                for s in &specs {
                    if !names.contains(s) {
                        names.push(s.clone());
                    }
                }
                let filters = names.iter().map(|n| spec::resolve(n)).collect::<Result<Vec<_>, _>>()?;
                let volumes =
                    if no_mni { vec![] } else { vec![boxforge_runtime::web::mni_volume(2).map_err(Failure)?] };
                let started = std::time::Instant::now();
                let site = boxforge_runtime::web::write_site(
                    &dir,
                    &filters,
                    &boxforge_runtime::web::SiteOptions { volumes },
                    |i, n, name| eprintln!("web: [{}/{n}] {name}", i + 1),
                )
                .map_err(Failure)?;
                outln!(
                    "{}: viewer for {} filters ({}), {} catalog modules, {} files, {:.1} MB in {:.1} s",
                    dir.display(),
                    site.filters.len(),
                    site.filters.join(", "),
                    site.modules,
                    site.files.len(),
                    site.bytes as f64 / 1e6,
                    started.elapsed().as_secs_f64()
                );
            }
            if serve {
                let server = boxforge_runtime::web::serve(&dir, port).map_err(Failure)?;
                outln!("serving {} at {} (Ctrl-C to stop)", dir.display(), server.url());
                server.run();
            } else {
                outln!("serve it with: boxforge web --serve -o {} (or any static file server; WebGPU needs https or localhost)", dir.display());
            }
            Ok(())
        }
        Command::List => {
            for name in spec::catalog::names() {
                let f = spec::catalog::get(name)?;
                outln!("{:<16} {:<9} {}", f.name, f.lattice.name, f.description);
            }
            for s in boxforge_runtime::render::schemes::ALL {
                outln!("{:<16} {:<9} {}", s.name(), "bcc", s.description());
            }
            Ok(())
        }
        Command::Validate { file, entries, json } => validate(&file, &entries, json),
        Command::Render {
            mode,
            tf,
            no_preintegration,
            cache,
            renderer,
            shading,
            qc,
            qc_grad,
            peel,
            filter,
            volume,
            raw,
            lattice,
            subset: _,
            resample,
            iso,
            size,
            view,
            perspective,
            no_skip,
            step,
            hit,
            layout,
            adapter,
            out,
        } => {
            let (az, el) = parse_view(&view)?;
            request::check_render_numbers(size, step, iso, az, el).map_err(Failure)?;
            request::check_output_file(&out, "--out").map_err(Failure)?;
            let dvr = request::check_render_mode(&mode, tf.as_deref(), no_preintegration).map_err(Failure)?;
            let perm = boxforge_runtime::render::perm::check_request(&cache, &mode, qc, qc_grad).map_err(Failure)?;
            if peel && perm.is_none() {
                return Err(Failure("--peel peels the PERM cache: add --cache perm (with --mode dvr)".into()));
            }
            let pt = request::check_renderer(&renderer, &mode, &cache, perspective).map_err(Failure)?;
            let tf = match &dvr {
                Some(name) => {
                    Some(boxforge_runtime::render::dvr::transfer::TransferFunction::load(name).map_err(Failure)?)
                }
                None => None,
            };
            // Mattausch et al.'s hand-written plane-stack schemes: ray-cast DVR on BCC only.
            let scheme = boxforge_runtime::render::schemes::Scheme::parse(&filter);
            if let Some(s) = scheme {
                request::check_scheme(s.name(), &mode, &cache, pt, &layout).map_err(Failure)?;
            }
            let mut f = match scheme {
                Some(_) => spec::resolve("bcc_linear")?,
                None => spec::resolve(&filter)?,
            };
            if f.view_dependent {
                // The variant for this frame's view (Mattausch et al.: shear
                // planes and shear direction follow the view direction).
                let (f_view, choice) = f.view_variant(render::view_direction(az, el))?;
                eprintln!("{choice}");
                f = f_view;
            }
            let d = Derivation::new(&f)?;
            if d.facts.dim != 3 {
                return Err(Failure(format!("{} is {}D: render needs a 3D filter", f.name, d.facts.dim)));
            }
            let lat = match lattice {
                Some(l) => boxforge::spec::lattice::Lattice::builtin(&l)?,
                None => f.lattice.clone(),
            };
            if lat != f.lattice {
                return Err(Failure(format!(
                    "filter {} is defined on the {} lattice, not {}: pick a filter for that lattice",
                    f.name, f.lattice.name, lat.name
                )));
            }
            if pt && boxforge_runtime::render::pt::tets::Grid::of(&lat).is_none() {
                return Err(Failure(format!(
                    "--renderer pt has tetrahedral meshes for BCC and CC data, not the {} lattice of {}: pick a BCC or CC filter, or drop --renderer pt",
                    lat.name, f.name
                )));
            }
            let conversion = if resample { Conversion::Resample } else { Conversion::Subset };
            let vol = scene::load(&volume, raw.as_deref(), &lat, conversion).map_err(|e| Failure(e.to_string()))?;
            let (lo, hi) = vol.data.iter().fold((f32::INFINITY, f32::NEG_INFINITY), |(a, b), &v| (a.min(v), b.max(v)));
            let warning = match &tf {
                Some(tf) => request::tf_warning(&tf.table(), lo, hi),
                None => request::iso_warning(iso, lo, hi),
            };
            if let Some(w) = warning {
                eprintln!("{w}");
            }
            let gpu = Gpu::new(adapter.as_deref()).map_err(|e| Failure(e.to_string()))?;
            request::check_image_limits(size, &gpu.limits()).map_err(Failure)?;
            let opts = RenderOptions {
                iso,
                width: size,
                height: size,
                azimuth: az,
                elevation: el,
                perspective,
                skip: !no_skip,
                step,
                hit: render::HitMode::parse(&hit).expect("clap checked"),
                progress: true,
                frames: 1,
                ..RenderOptions::default()
            };
            let shown = scheme.map_or(f.name.as_str(), |s| s.name());
            eprintln!("rendering {} ({} samples) with {shown} on {} ...", volume, vol.samples(), gpu.describe());
            let layout = Layout::parse(&layout).expect("clap checked");
            let frame = match &tf {
                Some(tf) => {
                    let o = boxforge_runtime::render::dvr::DvrOptions {
                        width: size,
                        height: size,
                        azimuth: az,
                        elevation: el,
                        perspective,
                        skip: !no_skip,
                        preintegrate: !no_preintegration,
                        step,
                        progress: true,
                        frames: 1,
                        ..Default::default()
                    };
                    match perm {
                        _ if scheme.is_some() => {
                            boxforge_runtime::render::schemes::render(&gpu, &vol, scheme.unwrap(), tf, &o).map(|(f, choice)| {
                                eprintln!("{choice}");
                                f
                            })
                        }
                        _ if pt => {
                            let shading = if shading == "gouraud" {
                                boxforge_runtime::render::pt::render::Shading::Gouraud
                            } else {
                                boxforge_runtime::render::pt::render::Shading::Phong
                            };
                            if d.facts.degree != 1 {
                                eprintln!("note: projected tetrahedra interpolate linearly on the tetrahedra; --filter {} sets only the lattice and the clipped box", d.filter.name);
                            }
                            let normals = boxforge_runtime::render::pt::render::Normals::Vertex;
                            boxforge_runtime::render::pt::render::render(&gpu, &d, &vol, tf, &o, shading, normals).map(|(f, st)| {
                                eprintln!(
                                    "projected tetrahedra: {} of {} tetrahedra visible, ordered in {:.0} ms",
                                    st.drawn, st.total, st.order_ms
                                );
                                f
                            })
                        }
                        Some(q) => boxforge_runtime::render::perm::render(&gpu, &d, &vol, layout, tf, &o, q, peel).map(|(f, c)| {
                            if peel {
                                eprintln!("opaque-boundary peeling: {} candidate cells no ray reaches dropped", c.peeled);
                            }
                            let n = c.counts;
                            eprintln!(
                                "PERM N={} M={}: {} of {} cells cached ({} visible), {:.0} ms preprocessing, {}",
                                q.density,
                                q.gradient,
                                n.candidates,
                                n.cells,
                                c.visible.iter().filter(|&&v| v).count(),
                                c.preprocess_ms,
                                c.memory.describe()
                            );
                            f
                        }),
                        None => boxforge_runtime::render::dvr::render(&gpu, &d, &vol, layout, tf, &o),
                    }
                }
                None => render::render(&gpu, &d, &vol, layout, &opts),
            }
            .map_err(|e| Failure(e.to_string()))?;
            render::write_png(&out, frame.width, frame.height, &frame.rgba)
                .map_err(|e| Failure(format!("cannot write {}: {e}", out.display())))?;
            if tf.is_some() {
                outln!(
                    "{}: {}x{} volume rendering in {:.1} ms per frame ({:.0}% of blocks transparent under the transfer function)",
                    out.display(),
                    size,
                    size,
                    frame.ms_per_frame,
                    frame.empty_blocks * 100.0
                );
            } else {
                outln!(
                    "{}: {}x{} in {:.1} ms per frame ({:.0}% of blocks empty)",
                    out.display(),
                    size,
                    size,
                    frame.ms_per_frame,
                    frame.empty_blocks * 100.0
                );
            }
            Ok(())
        }
        Command::Bench {
            filters,
            smoke,
            no_naive,
            no_quality,
            perm,
            no_references,
            derive,
            specs,
            literature,
            runs,
            json,
            markdown,
            wgsl,
            entry,
            like,
            adapter,
        } => {
            use boxforge_runtime::bench;
            if derive {
                let count = specs.unwrap_or(105);
                let started = std::time::Instant::now();
                let report = bench::derive::run(count);
                eprintln!("{} specs in {:.1} s", report.rows.len(), started.elapsed().as_secs_f64());
                let mut cmd = format!("boxforge bench --derive --specs {count}");
                if let Some(m) = &markdown {
                    cmd.push_str(&format!(" --markdown {}", m.display()));
                    let old = std::fs::read_to_string(m).unwrap_or_default();
                    let text = bench::derive::splice(&old, &bench::derive::markdown(&report, &cmd));
                    boxforge::build::output::write_atomic(m, text.as_bytes())?;
                    eprintln!("wrote the derivation section of {}", m.display());
                }
                if json {
                    outln!("{}", serde_json::to_string(&report).unwrap());
                } else if markdown.is_none() {
                    outln!("{}", bench::derive::markdown(&report, &cmd));
                }
                return Ok(());
            }
            if literature {
                let gpu = Gpu::new(adapter.as_deref()).map_err(|e| Failure(e.to_string()))?;
                eprintln!("benchmarking on {}", gpu.describe());
                let (points, rounds, pt_size) = if smoke { (4096, 2, 32) } else { (1 << 18, runs.unwrap_or(7), 256) };
                let mut cmd = String::from("boxforge bench --literature");
                if smoke {
                    cmd.push_str(" --smoke");
                }
                if let Some(m) = &markdown {
                    request::check_output_file(m, "--markdown").map_err(Failure)?;
                    cmd.push_str(&format!(" --markdown {}", m.display()));
                }
                let steps = progress::Steps::new();
                // The head at 2 mm (projected tetrahedra of the 1 mm head take about a minute a frame on lavapipe).
                let head = match (smoke, boxforge_runtime::scene::data_file("mni152_t1_1mm.nii.gz")) {
                    (false, Some(p)) => Some(
                        boxforge_runtime::volume::Volume::load_nifti(&p)
                            .map_err(|e| Failure(e.to_string()))?
                            .downsample(2),
                    ),
                    _ => None,
                };
                let report =
                    bench::literature::run(&gpu, points, rounds, pt_size, head.as_ref(), &|m: &str| steps.step(m));
                steps.finish();
                let report = report.map_err(Failure)?;
                let section = bench::literature::markdown(&report, &cmd);
                if let Some(m) = &markdown {
                    let old = std::fs::read_to_string(m).unwrap_or_default();
                    boxforge::build::output::write_atomic(m, bench::literature::splice(&old, &section).as_bytes())?;
                    eprintln!("wrote the literature section of {}", m.display());
                }
                if json {
                    outln!("{}", serde_json::to_string(&report).unwrap());
                } else if markdown.is_none() {
                    outln!("{section}");
                }
                return Ok(());
            }
            if perm {
                let gpu = Gpu::new(adapter.as_deref()).map_err(|e| Failure(e.to_string()))?;
                eprintln!("benchmarking on {}", gpu.describe());
                let (size, rounds) = if smoke { (32, 1) } else { (256, runs.unwrap_or(3)) };
                let mut cmd = String::from("boxforge bench --perm");
                if smoke {
                    cmd.push_str(" --smoke");
                }
                if let Some(r) = runs {
                    cmd.push_str(&format!(" --runs {r}"));
                }
                if let Some(m) = &markdown {
                    request::check_output_file(m, "--markdown").map_err(Failure)?;
                    cmd.push_str(&format!(" --markdown {}", m.display()));
                }
                let head = match (smoke, boxforge_runtime::scene::data_file("mni152_t1_1mm.nii.gz")) {
                    (false, Some(p)) => {
                        Some(boxforge_runtime::volume::Volume::load_nifti(&p).map_err(|e| Failure(e.to_string()))?)
                    }
                    _ => None,
                };
                let steps = progress::Steps::new();
                let report = bench::perm::run(&gpu, head.as_ref(), size, rounds, &|m: &str| steps.step(m));
                steps.finish();
                let report = report.map_err(Failure)?;
                let section = bench::perm::markdown(&report, &cmd);
                if let Some(m) = &markdown {
                    let old = std::fs::read_to_string(m).unwrap_or_default();
                    boxforge::build::output::write_atomic(m, bench::perm::splice(&old, &section).as_bytes())?;
                    eprintln!("wrote the PERM section of {}", m.display());
                }
                if json {
                    outln!("{}", serde_json::to_string(&report).unwrap());
                } else if markdown.is_none() {
                    outln!("{section}");
                }
                return Ok(());
            }
            let external = match (wgsl, entry, like) {
                (Some(w), Some(e), Some(l)) => Some(bench::External { wgsl: w, entry: e, like: l }),
                (None, None, None) => None,
                _ => return Err(Failure("--wgsl, --entry and --like go together: give all three".into())),
            };
            let mut o = match (&external, filters.is_empty()) {
                // An external shader alone times only that pair.
                (Some(x), true) => bench::BenchOptions::external_only(x.clone()),
                _ if smoke => bench::BenchOptions::smoke(),
                _ => bench::BenchOptions::full(),
            };
            if !filters.is_empty() {
                o.filters = filters;
            }
            o.naive &= !no_naive;
            o.quality &= !no_quality;
            // The CLI's smoke run includes the references (the library's
            // smoke options, used by the CI test, leave them to bench_refs).
            o.references = (o.references || smoke) && !no_references;
            if let Some(r) = runs {
                o.runs = r.max(1);
            }
            if external.is_some() {
                o.external = external;
            }
            bench::check_inputs(&o).map_err(Failure)?;
            if let Some(m) = &markdown {
                request::check_output_file(m, "--markdown").map_err(Failure)?;
            }
            let gpu = Gpu::new(adapter.as_deref()).map_err(|e| Failure(e.to_string()))?;
            eprintln!("benchmarking on {}", gpu.describe());
            let mut cmd = String::from("boxforge bench");
            if smoke {
                cmd.push_str(" --smoke");
            }
            if let Some(r) = runs {
                cmd.push_str(&format!(" --runs {r}"));
            }
            if let Some(m) = &markdown {
                cmd.push_str(&format!(" --markdown {}", m.display()));
            }
            // Keep the derivation section (`bench --derive`) of an existing file.
            let old = markdown.as_ref().and_then(|m| std::fs::read_to_string(m).ok()).unwrap_or_default();
            let write_markdown = |report: &bench::BenchReport| -> Result<(), Failure> {
                if let Some(m) = &markdown {
                    let mut text = bench::markdown(report, &cmd);
                    if let Some(section) = bench::derive::existing_section(&old) {
                        text = format!("{}\n\n{section}\n", text.trim_end());
                    }
                    if let Some(section) = bench::literature::existing_section(&old) {
                        text = format!("{}\n\n{section}\n", text.trim_end());
                    }
                    if let Some(section) = bench::perm::existing_section(&old) {
                        text = format!("{}\n\n{section}\n", text.trim_end());
                    }
                    boxforge::build::output::write_atomic(m, text.as_bytes())?;
                }
                Ok(())
            };
            let steps = progress::Steps::new();
            // Every snapshot is written as it comes: an interrupted run keeps what it measured.
            let report = bench::run_with(&gpu, &o, &|m: &str| steps.step(m), &|partial| {
                if let Err(Failure(e)) = write_markdown(partial) {
                    steps.println(&format!("warning: could not save the partial report: {e}"));
                }
            });
            steps.finish();
            let report = report.map_err(Failure)?;
            if let Some(m) = &markdown {
                write_markdown(&report)?;
                eprintln!("wrote {}", m.display());
            }
            if json {
                outln!("{}", serde_json::to_string(&report).expect("the report serialises"));
            } else if markdown.is_none() {
                outln!("{}", bench::markdown(&report, &cmd));
            }
            Ok(())
        }
        Command::Demo { out, size, adapter } => {
            request::check_image_edge(size).map_err(Failure)?;
            request::check_output_dir(&out, "--out").map_err(Failure)?;
            demo::run(&out, size, adapter.as_deref()).map_err(Failure)
        }
        Command::Verify { filter, layout, variant, form, bounds, fetch, points, seed, adapter, json } => {
            request::check_points(points).map_err(Failure)?;
            let f = spec::resolve(&filter)?;
            let d = Derivation::new(&f)?;
            let gpu = boxforge_runtime::gpu::Gpu::new(adapter.as_deref()).map_err(|e| Failure(e.to_string()))?;
            let layout = Layout::parse(&layout).expect("clap checked");
            let variant = Variant::parse(&variant).expect("clap checked");
            let form = form.map(|f| boxforge::emit::EvalForm::parse(&f).expect("clap checked"));
            let bounds = boxforge::emit::Bounds::parse(&bounds).expect("clap checked");
            let fetch = boxforge::emit::FetchMode::parse(&fetch).expect("clap checked");
            let r =
                boxforge_runtime::verify::verify_fetch(&gpu, &d, layout, variant, form, bounds, fetch, points, seed)
                    .map_err(|e| Failure(e.to_string()))?;
            if json {
                outln!("{}", serde_json::to_string(&r).unwrap());
            } else {
                outln!(
                    "{} ({}, {}, form {}, {} {} fetches) on {}: {} points, max |value error| {:.3e} (range {:.3}), max relative gradient error {:.3e}: {}",
                    r.filter,
                    layout.name(),
                    variant.name(),
                    r.form.name(),
                    r.bounds.name(),
                    r.fetch.name(),
                    r.adapter,
                    r.points,
                    r.max_abs_err,
                    r.data_range,
                    r.max_rel_grad_err,
                    if r.passed { "PASSED" } else { "FAILED" }
                );
            }
            if r.passed {
                Ok(())
            } else {
                std::process::exit(1)
            }
        }
        Command::Generate { filters, all, out, layout, variant, form, fetch, check } => {
            let fetch = boxforge::emit::FetchMode::parse(&fetch).expect("clap checked");
            if !check {
                request::check_output_dir(&out, "--out").map_err(Failure)?;
            }
            let names = filter_names(filters.clone(), all)?;
            let mut resolved = names.iter().map(|n| spec::resolve(n)).collect::<Result<Vec<_>, _>>()?;
            if let Some(f) = &form {
                let f = boxforge::emit::EvalForm::parse(f).expect("clap checked");
                resolved.iter_mut().for_each(|r| r.form = f);
            }
            let layouts: Vec<Layout> = match &layout {
                Some(l) => vec![Layout::parse(l).expect("clap checked")],
                None => ALL_LAYOUTS.to_vec(),
            };
            let variants: Vec<Variant> = match &variant {
                Some(v) => vec![Variant::parse(v).expect("clap checked")],
                // Linear fetches are a fast-variant feature.
                None if fetch == boxforge::emit::FetchMode::Linear => vec![Variant::Fast],
                None => ALL_VARIANTS.to_vec(),
            };
            let mut what = if all { "--all".to_string() } else { filters.join(" ") };
            if let Some(l) = &layout {
                what.push_str(&format!(" --layout {l}"));
            }
            if let Some(v) = &variant {
                what.push_str(&format!(" --variant {v}"));
            }
            if let Some(f) = &form {
                what.push_str(&format!(" --form {f}"));
            }
            if fetch == boxforge::emit::FetchMode::Linear {
                what.push_str(" --fetch linear");
            }
            let command = format!("boxforge generate {what} -o {}", out.display());
            let started = std::time::Instant::now();
            let derivations = derive_all(&resolved, |d, t| (d, t))?;
            let mut stale = Vec::new();
            for (d, seconds) in &derivations {
                // Without --layout, linear fetches go where they apply: packed for
                // any lattice with 2Z^s, embedded for one-coset tensor products.
                let layouts: Vec<Layout> = if layout.is_none() && fetch == boxforge::emit::FetchMode::Linear {
                    let mut l = Vec::new();
                    if d.factorisation().is_some_and(|f| f.supports_linear_fetch()) {
                        l.push(Layout::Embedded);
                    }
                    if boxforge::emit::coset_pivots(&d.filter.lattice).is_ok() {
                        l.push(Layout::Packed);
                    }
                    l
                } else {
                    layouts.clone()
                };
                let files = boxforge::build::output::generated_files_with(d, &command, &layouts, &variants, fetch)?;
                if check {
                    for (name, text) in &files {
                        if std::fs::read_to_string(out.join(name)).ok().as_deref() != Some(text.as_str()) {
                            stale.push(out.join(name).display().to_string());
                        }
                    }
                } else {
                    let written = boxforge::build::output::write_files(&out, &files)?;
                    let list: Vec<String> = written.iter().map(|p| p.display().to_string()).collect();
                    eprintln!("{:<16} derived in {seconds:.2} s: {}", d.filter.name, list.join(", "));
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
        Command::Inspect { filters, all, json, timings } => {
            let names = filter_names(filters, all)?;
            let resolved = names.iter().map(|n| spec::resolve(n)).collect::<Result<Vec<_>, _>>()?;
            let reports = derive_all(&resolved, |d, seconds| {
                let mut r = Report::new(&d);
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
    }
}

fn parse_view(v: &str) -> Result<(f32, f32), Failure> {
    let parts: Vec<&str> = v.split(',').collect();
    match parts.as_slice() {
        [a, e] => match (a.trim().parse(), e.trim().parse()) {
            (Ok(a), Ok(e)) => Ok((a, e)),
            _ => Err(Failure(format!("--view {v}: expected AZ,EL in degrees, e.g. --view 30,25"))),
        },
        _ => Err(Failure(format!("--view {v}: expected AZ,EL in degrees, e.g. --view 30,25"))),
    }
}

/// `boxforge validate`: exit 0 when valid and branch-free, 1 otherwise.
fn validate(file: &std::path::Path, entries: &[String], json: bool) -> Result<(), Failure> {
    let source = std::fs::read_to_string(file)
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
        entries.to_vec()
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

/// Derives filters one after another, each one's reference pieces in
/// parallel on every core, with a progress bar on a terminal for
/// derivations of more than a few thousand polynomials; maps each result
/// with the seconds it took.
fn derive_all<T>(filters: &[boxforge::Filter], map: impl Fn(Derivation, f64) -> T) -> Result<Vec<T>, Failure> {
    let mut out = Vec::with_capacity(filters.len());
    for f in filters {
        let started = std::time::Instant::now();
        let d = Derivation::new(f)?;
        let bar = progress::derivation_bar(&d);
        d.derive_all_forms(&|done, _| bar.set_position(done as u64));
        bar.finish_and_clear();
        out.push(map(d, started.elapsed().as_secs_f64()));
    }
    Ok(out)
}
