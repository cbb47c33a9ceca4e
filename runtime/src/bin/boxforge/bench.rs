//! `boxforge bench`: the main benchmark (evaluation throughput, rendering,
//! gradients, quality), and the modes that write their own section of the
//! Markdown file (`--derive`, `--literature`, `--perm`).

use crate::common::{Failure, Section};
use crate::request;
use boxforge_runtime::bench;
use boxforge_runtime::gpu::Gpu;
use boxforge_runtime::volume::Volume;
use boxforge_runtime::{progress, scene};
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct BenchArgs {
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
    /// Measure volumes larger than one texture instead: bricked vs embedded
    /// and u8 vs f32 in core, and out-of-core frames of a generated
    /// Marschner-Lobb u8 volume on disk (1024^3, about 1 GiB, written once
    /// into the cache folder) at 1 GiB and 256 MiB budgets, and of a volume
    /// longer than the 3D texture limit: with --markdown, replaces only its
    /// section of the file.
    #[arg(long, conflicts_with_all = ["derive", "literature", "perm"])]
    volumes: bool,
    /// Measure second derivatives instead: the generated eval_hessian of
    /// every filter of degree >= 2 against central differences of its
    /// analytic gradient, and against the hand-written Hessians (the
    /// separable tricubic, Kim's bcc7, Kim & Kim's cc6): with --markdown,
    /// replaces only its section of the file.
    #[arg(long, conflicts_with_all = ["derive", "literature", "perm", "volumes"])]
    hessian: bool,
    /// Measure curvature fidelity instead (CPU, no device): the error of
    /// the principal curvatures on a sphere against the sample spacing, the
    /// measured order beside approximation order - 2, for every filter of
    /// degree >= 2: with --markdown, replaces only its section of the file.
    #[arg(long, conflicts_with_all = ["derive", "literature", "perm", "volumes", "hessian"])]
    curvature: bool,
    /// Measure the 4D catalog filters instead: D4* against Z^4 (and BCC x Z)
    /// at matched sample counts on the drifting Marschner-Lobb space-time
    /// signal (RMS, prefiltered and plain) and evals/s per 4D filter: with
    /// --markdown, replaces only its section of the file.
    #[arg(long, conflicts_with_all = ["derive", "literature", "perm", "volumes", "hessian", "curvature"])]
    four_d: bool,
    /// Measure pyramid levels for spline reconstruction instead (CPU, no
    /// device): RMS of each level of Marschner-Lobb per reduction (subsample,
    /// box, binomial) and filter; with --markdown, replaces only its section.
    #[arg(long, conflicts_with_all = ["derive", "literature", "perm", "volumes", "hessian", "curvature", "four_d"])]
    pyramid: bool,
    /// Edge of the generated out-of-core volume (default 1024; 64 with --smoke).
    #[arg(long, requires = "volumes")]
    large_edge: Option<usize>,
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
    /// Measure only the generated-vs-hand-written table (every built-in
    /// reference, both kernel shapes): with --markdown, replaces only that
    /// section of the file.
    #[arg(long, conflicts_with_all = ["derive", "literature", "perm", "no_references", "filters"])]
    references_only: bool,
    /// Interleaved timing rounds per comparison (default: 7, or 3 with --smoke).
    #[arg(long)]
    runs: Option<usize>,
    #[arg(long)]
    json: bool,
    /// Write the report as Markdown (e.g. docs/BENCHMARKS.md).
    #[arg(long)]
    markdown: Option<PathBuf>,
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
}

pub fn run(a: BenchArgs) -> Result<(), Failure> {
    if a.derive {
        derive(&a)
    } else if a.literature {
        literature(&a)
    } else if a.perm {
        perm(&a)
    } else if a.volumes {
        volumes(&a)
    } else if a.hessian {
        hessian(&a)
    } else if a.four_d {
        four_d(&a)
    } else if a.curvature {
        curvature(&a)
    } else if a.pyramid {
        crate::bench_pyramid::run(&a.filters, a.smoke, a.markdown.as_deref(), a.json)
    } else if a.references_only {
        references_only(&a)
    } else {
        main_report(a)
    }
}

/// ` --smoke` and ` --runs R` as given, for the command line in the file.
/// The library's error, naming the flag an input came from.
impl From<bench::BenchError> for Failure {
    fn from(e: bench::BenchError) -> Failure {
        match e {
            bench::BenchError::ExternalShader { path, reason } => {
                Failure(format!("cannot read --wgsl {path}: {reason} (check the path)"))
            }
            e => Failure(e.to_string()),
        }
    }
}

fn smoke_runs(a: &BenchArgs, with_runs: bool) -> String {
    let mut flags = String::new();
    if a.smoke {
        flags.push_str(" --smoke");
    }
    if let (true, Some(r)) = (with_runs, a.runs) {
        flags.push_str(&format!(" --runs {r}"));
    }
    flags
}

fn open_gpu(adapter: Option<&str>) -> Result<Gpu, Failure> {
    let gpu = Gpu::new(adapter).map_err(|e| Failure(e.to_string()))?;
    eprintln!("benchmarking on {}", gpu.describe());
    Ok(gpu)
}

/// The MNI head (not in smoke runs, nor when data/ lacks it).
fn head(smoke: bool) -> Result<Option<Volume>, Failure> {
    match (smoke, scene::data_file("mni152_t1_1mm.nii.gz")) {
        (false, Some(p)) => Ok(Some(Volume::load_nifti(&p).map_err(|e| Failure(e.to_string()))?)),
        _ => Ok(None),
    }
}

/// `--derive`: derivation times of seeded random specs (no GPU).
fn derive(a: &BenchArgs) -> Result<(), Failure> {
    let count = a.specs.unwrap_or(105);
    let section = Section::new("derivation", &format!("--derive --specs {count}"), a.markdown.as_deref())?;
    let started = std::time::Instant::now();
    let report = bench::derive::run(count);
    eprintln!("{} specs in {:.1} s", report.rows.len(), started.elapsed().as_secs_f64());
    let text = bench::derive::markdown(&report, section.command());
    section.finish(&report, &text, bench::derive::splice, a.json)
}

/// `--literature`: the source papers' reconstructions and renderers.
fn literature(a: &BenchArgs) -> Result<(), Failure> {
    let gpu = open_gpu(a.adapter.as_deref())?;
    let (points, rounds, pt_size) = if a.smoke { (4096, 2, 32) } else { (1 << 18, a.runs.unwrap_or(7), 256) };
    let flags = format!("--literature{}", smoke_runs(a, false));
    let section = Section::new("literature", &flags, a.markdown.as_deref())?;
    let steps = progress::Steps::new();
    // The head at 2 mm (projected tetrahedra of the 1 mm head take about a minute a frame on lavapipe).
    let head = head(a.smoke)?.map(|h| h.downsample(2));
    let report = bench::literature::run(&gpu, points, rounds, pt_size, head.as_ref(), &|m: &str| steps.step(m));
    steps.finish();
    let report = report?;
    let text = bench::literature::markdown(&report, section.command());
    section.finish(&report, &text, bench::literature::splice, a.json)
}

/// `--references-only`: the generated-vs-hand-written table alone.
fn references_only(a: &BenchArgs) -> Result<(), Failure> {
    let gpu = open_gpu(a.adapter.as_deref())?;
    let o = if a.smoke { bench::BenchOptions::smoke() } else { bench::BenchOptions::full() };
    let rounds = a.runs.map_or(o.runs, |r| r.max(1));
    let flags = format!("--references-only{}", smoke_runs(a, true));
    let section = Section::new("generated-vs-hand-written", &flags, a.markdown.as_deref())?;
    let steps = progress::Steps::new();
    let mut rows = Vec::new();
    for r in boxforge_runtime::references::builtin() {
        steps.step(&format!("{} vs {}_eval, {rounds} rounds", r.name, r.like));
        rows.push(bench::compare_reference(&gpu, &r, o.points, rounds)?);
    }
    let mut glsl = Vec::new();
    for r in bench::glsl_rivals::builtin() {
        steps.step(&format!("{} vs {}_eval in GLSL, {rounds} rounds", r.name, r.like));
        glsl.push(bench::glsl_rivals::compare_glsl(&gpu, &r, o.points, rounds)?);
    }
    steps.finish();
    let measured_by = format!(
        "This section was measured by its own run, `{}` on {} ({} interleaved rounds), not by the run that wrote the rest of the file.",
        section.command(),
        gpu.describe(),
        rounds
    );
    let text = bench::references_section(&rows, &glsl, Some(&measured_by));
    let report = serde_json::json!({ "references": rows, "glsl_references": glsl });
    section.finish(&report, &text, bench::splice_references, a.json)
}

/// `--perm`: Lim and Shin's PERM cache against direct evaluation.
fn perm(a: &BenchArgs) -> Result<(), Failure> {
    let gpu = open_gpu(a.adapter.as_deref())?;
    let (size, rounds) = if a.smoke { (32, 1) } else { (256, a.runs.unwrap_or(3)) };
    let flags = format!("--perm{}", smoke_runs(a, true));
    let section = Section::new("PERM", &flags, a.markdown.as_deref())?;
    let head = head(a.smoke)?;
    let steps = progress::Steps::new();
    let report = bench::perm::run(&gpu, head.as_ref(), size, rounds, &|m: &str| steps.step(m));
    steps.finish();
    let report = report?;
    let text = bench::perm::markdown(&report, section.command());
    section.finish(&report, &text, bench::perm::splice, a.json)
}

/// `--hessian`: eval_hessian against central differences and the separable tricubic Hessian.
fn hessian(a: &BenchArgs) -> Result<(), Failure> {
    let filters: Vec<String> = if !a.filters.is_empty() {
        a.filters.clone()
    } else if a.smoke {
        vec!["cc_tricubic".into()]
    } else {
        ["cc_triquadratic", "cc_tricubic", "bcc7", "bcc8", "bcc12", "fcc6", "cc6"].map(String::from).to_vec()
    };
    let (points, rounds) = if a.smoke { (4096, 1) } else { (1 << 18, a.runs.unwrap_or(7)) };
    let mut flags = format!("--hessian{}", smoke_runs(a, true));
    if !a.filters.is_empty() {
        flags.push_str(&format!(" --filters {}", a.filters.join(",")));
    }
    let section = Section::new("second-derivatives", &flags, a.markdown.as_deref())?;
    let gpu = open_gpu(a.adapter.as_deref())?;
    let steps = progress::Steps::new();
    let report = bench::hessian::run(&gpu, &filters, points, rounds, &|m: &str| steps.step(m));
    steps.finish();
    let report = report.map_err(|e| Failure(e.to_string()))?;
    let text = bench::hessian::markdown(&report, section.command());
    section.finish(&report, &text, bench::hessian::splice, a.json)
}

/// `--four-d`: the 4D filters' quality at matched sample counts and their speed.
fn four_d(a: &BenchArgs) -> Result<(), Failure> {
    let names: Vec<String> = if a.filters.is_empty() {
        boxforge::spec::catalog::names().into_iter().map(String::from).collect()
    } else {
        a.filters.clone()
    };
    let mut flags = format!("--four-d{}", smoke_runs(a, true));
    if !a.filters.is_empty() {
        flags.push_str(&format!(" --filters {}", a.filters.join(",")));
    }
    let section = Section::new("four-dimensions", &flags, a.markdown.as_deref())?;
    let gpu = open_gpu(a.adapter.as_deref())?;
    let on_cpu = gpu.info.device_type == wgpu::DeviceType::Cpu;
    // Two sample budgets (Z^4 points per axis over [-1, 1]^4).
    let (budgets, points, speed_points, rounds): (&[usize], usize, usize, usize) = if a.smoke {
        (&[8], 2000, 2000, 1)
    } else {
        (&[32, 48], 20_000, if on_cpu { 1 << 14 } else { 1 << 20 }, a.runs.unwrap_or(5))
    };
    let mut filters = Vec::new();
    for name in &names {
        let d = boxforge::derive::Derivation::new(&boxforge::spec::resolve(name)?)?;
        if d.facts.dim == 4 {
            filters.push(d);
        }
    }
    if filters.is_empty() {
        return Err(Failure(format!("--four-d: none of {} is a 4D filter; name 4D filters or none", names.join(", "))));
    }
    let steps = progress::Steps::new();
    let mut quality = Vec::new();
    let mut speed = Vec::new();
    let mut run = || -> Result<(), boxforge_runtime::bench::BenchError> {
        for &n in budgets {
            for d in &filters {
                steps.step(&format!("{}: RMS at the Z^4 budget n = {n}", d.filter.name));
                quality.push(bench::four::quality(&gpu, d, n, points)?);
            }
        }
        for d in &filters {
            steps.step(&format!("{}: evals/s", d.filter.name));
            speed.push(bench::four::speed(&gpu, d, speed_points, rounds)?);
        }
        Ok(())
    };
    let result = run();
    steps.finish();
    result.map_err(|e| Failure(e.to_string()))?;
    let report = bench::four::FourDReport { adapter: gpu.describe(), points, quality, speed };
    let text = bench::four::markdown(&report, section.command());
    section.finish(&report, &text, bench::four::splice, a.json)
}

/// `--curvature`: the curvature error's order of convergence per filter.
fn curvature(a: &BenchArgs) -> Result<(), Failure> {
    let names: Vec<String> = if a.filters.is_empty() {
        boxforge::spec::catalog::names().into_iter().map(String::from).collect()
    } else {
        a.filters.clone()
    };
    let points = if a.smoke { 50 } else { 2000 };
    let mut flags = format!("--curvature{}", smoke_runs(a, false));
    if !a.filters.is_empty() {
        flags.push_str(&format!(" --filters {}", a.filters.join(",")));
    }
    let section = Section::new("curvature", &flags, a.markdown.as_deref())?;
    let steps = progress::Steps::new();
    let mut rows = Vec::new();
    for name in &names {
        let f = boxforge::spec::resolve(name)?;
        let d = boxforge::derive::Derivation::new(&f)?;
        if d.facts.dim != 3 || d.facts.degree < 2 || f.view_dependent {
            continue;
        }
        for signal in [bench::curvature::Signal::Sphere, bench::curvature::Signal::MarschnerLobb] {
            steps.step(&format!("{name}: curvature error on {signal:?} at {} spacings", signal.cells_per_unit().len()));
            rows.push(bench::curvature::curvature_order_of(&d, signal, points));
        }
    }
    steps.finish();
    let text = bench::curvature::markdown(&rows, points, section.command());
    section.finish(&rows, &text, bench::curvature::splice, a.json)
}

/// `--volumes`: bricks, compact formats and out-of-core frames.
fn volumes(a: &BenchArgs) -> Result<(), Failure> {
    let gpu = open_gpu(a.adapter.as_deref())?;
    // A frame on a real GPU must outlast its submission and wait (~0.1 ms),
    // and the f32 volume must outgrow the caches for the formats to differ:
    // there the in-core volume is 256^3 (64 MiB in f32) and the frame 1024^2.
    let on_cpu = gpu.info.device_type == wgpu::DeviceType::Cpu;
    let (edge, size, rounds) = match (a.smoke, on_cpu) {
        (true, _) => (32, 64, 1),
        (false, true) => (128, 256, a.runs.unwrap_or(5)),
        (false, false) => (256, 1024, a.runs.unwrap_or(9)),
    };
    let large = a.large_edge.unwrap_or(if a.smoke { 64 } else { 1024 });
    let mut flags = format!("--volumes{}", smoke_runs(a, true));
    if a.large_edge.is_some() {
        flags.push_str(&format!(" --large-edge {large}"));
    }
    let section = Section::new("volumes", &flags, a.markdown.as_deref())?;
    let steps = progress::Steps::new();
    let mut in_core = Vec::new();
    for f in ["bcc7", "cc_tricubic"] {
        in_core.extend(
            bench::volumes::in_core(&gpu, f, edge, size, rounds, &|m: &str| steps.step(m))
                .map_err(|e| Failure(e.to_string()))?,
        );
    }
    steps.finish();
    let cache = boxforge_runtime::volume::default_cache_dir();
    let (budgets, long): (Vec<u64>, [usize; 3]) =
        if a.smoke { (vec![16 << 20, 4 << 20], [160, 32, 32]) } else { (vec![1 << 30, 256 << 20], [2304, 256, 256]) };
    let write = |dims: [usize; 3]| -> Result<std::path::PathBuf, Failure> {
        let path = cache.join(format!("ml_{}x{}x{}_u8.raw", dims[0], dims[1], dims[2]));
        let last = std::cell::Cell::new(usize::MAX);
        let wrote = bench::volumes::write_ml_u8(&path, dims, &|done, total| {
            let pct = done * 100 / total;
            if pct / 10 != last.get() / 10 {
                last.set(pct);
                eprintln!("writing {}: {pct}%", path.display());
            }
        })
        .map_err(|e| Failure(format!("cannot write {}: {e}", path.display())))?;
        if !wrote {
            eprintln!("using {} (already written)", path.display());
        }
        Ok(path)
    };
    let cube = write([large; 3])?;
    let long_path = write(long)?;
    let exe = std::env::current_exe().map_err(|e| Failure(format!("cannot find this program: {e}")))?;
    let out_png = std::env::temp_dir().join(format!("boxforge-volumes-{}.png", std::process::id()));
    let child = |filter: &str,
                 volume: &str,
                 raw: Option<String>,
                 budget: u64,
                 iso: Option<&str>|
     -> Result<serde_json::Value, Failure> {
        let mut cmd = std::process::Command::new(&exe);
        cmd.args(["render", "--filter", filter, "--volume", volume, "--format", "u8", "--size"]).arg(size.to_string());
        // An isosurface at `iso`, or a volume rendering under the default ramp.
        match iso {
            Some(iso) => cmd.args(["--iso", iso]),
            None => cmd.args(["--mode", "dvr"]),
        };
        cmd.args(["--gpu-budget", &budget.to_string(), "--stats-json", "--no-bounds-cache", "--out"]).arg(&out_png);
        if let Some(r) = raw {
            cmd.args(["--raw", &r]);
        }
        if let Some(ad) = &a.adapter {
            cmd.args(["--adapter", ad]);
        }
        eprintln!("{filter} {volume} at {}", boxforge_runtime::render::paged::human(budget));
        let out = cmd.stderr(std::process::Stdio::inherit()).output().map_err(|e| Failure(e.to_string()))?;
        if !out.status.success() {
            return Err(Failure(format!(
                "out-of-core render of {volume} with {filter} failed (exit {:?})",
                out.status.code()
            )));
        }
        serde_json::from_slice(&out.stdout).map_err(|e| Failure(format!("unreadable render statistics: {e}")))
    };
    let mut out_of_core = Vec::new();
    // Isosurfaces of both filters at every budget and bcc7's of the long
    // volume; then bcc7's volume renderings at the smallest budget.
    let smallest = budgets[budgets.len() - 1];
    for (f, dvr) in [("bcc7", false), ("cc_tricubic", false), ("bcc7", true)] {
        let iso = |v: &'static str| (!dvr).then_some(v);
        let base = child(f, "ml:8", None, smallest, iso("0.5"))?["host_peak_bytes"].as_u64();
        let cubes = if dvr { vec![smallest] } else { budgets.clone() };
        let runs: Vec<(std::path::PathBuf, [usize; 3], u64)> = cubes
            .iter()
            .map(|&b| (cube.clone(), [large; 3], b))
            .chain((f == "bcc7").then(|| (long_path.clone(), long, smallest / 4)))
            .collect();
        for (path, dims, budget) in runs {
            let raw = format!("{},{},{},u8", dims[0], dims[1], dims[2]);
            let stats = child(f, &path.display().to_string(), Some(raw), budget, iso("127.5"))?;
            out_of_core.push(bench::volumes::OutOfCoreRow {
                filter: if dvr { format!("{f} (DVR)") } else { f.into() },
                volume: format!(
                    "ML {}x{}x{} u8 on disk ({} MiB)",
                    dims[0],
                    dims[1],
                    dims[2],
                    dims.iter().product::<usize>() >> 20
                ),
                format: "u8".into(),
                budget,
                stats,
                baseline_host_bytes: base,
            });
        }
    }
    let _ = std::fs::remove_file(&out_png);
    let report = bench::volumes::VolumesReport {
        adapter: gpu.describe(),
        in_core_volume: format!("Marschner-Lobb, {edge}^3 box"),
        size,
        rounds,
        in_core,
        out_of_core,
    };
    let text = bench::volumes::markdown(&report, section.command());
    section.finish(&report, &text, bench::volumes::splice, a.json)
}

/// The main report: throughput, rendering, gradients, quality; with
/// --markdown the whole file, keeping the other modes' sections.
fn main_report(a: BenchArgs) -> Result<(), Failure> {
    let BenchArgs { filters, smoke, no_naive, no_quality, no_references, runs, json, markdown, .. } = a;
    let external = match (a.wgsl, a.entry, a.like) {
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
    bench::check_inputs(&o)?;
    if let Some(m) = &markdown {
        request::check_output_file(m, "--markdown")?;
    }
    let gpu = open_gpu(a.adapter.as_deref())?;
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
    // Keep the sections of the other modes (`bench --derive`, `--literature`, `--perm`, ...) and the GPU record of an existing file.
    let old = markdown.as_ref().and_then(|m| std::fs::read_to_string(m).ok()).unwrap_or_default();
    let write_markdown = |report: &bench::BenchReport| -> Result<(), Failure> {
        if let Some(m) = &markdown {
            let mut text = bench::markdown(report, &cmd);
            let kept = [
                bench::derive::existing_section(&old),
                bench::literature::existing_section(&old),
                bench::perm::existing_section(&old),
                bench::volumes::existing_section(&old),
                bench::hessian::existing_section(&old),
                bench::curvature::existing_section(&old),
                bench::levels::existing_section(&old),
                bench::four::existing_section(&old),
                bench::markdown::gpu_record_section(&old),
                // The Python package's benches (python/bench/), pasted in by hand.
                bench::derive::section_between(
                    &old,
                    "<!-- python-spline-bench:start -->",
                    "<!-- python-spline-bench:end -->",
                ),
                bench::derive::section_between(
                    &old,
                    "<!-- python-dask-bench:start -->",
                    "<!-- python-dask-bench:end -->",
                ),
            ];
            for section in kept.into_iter().flatten() {
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
    let report = report?;
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
