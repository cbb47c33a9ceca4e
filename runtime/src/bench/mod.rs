//! `boxforge bench`: every claim gets a number, measured in one run. Every
//! comparison is timed in interleaved rounds (each contender once per round,
//! rotating which goes first), the ratio is taken per round, and the report
//! gives the median ratio with its min..max over rounds (a range spanning 1.0
//! is a tie).

pub mod derive;
pub mod dvr;
pub mod hit;
pub mod literature;
pub mod perm;

pub mod stats;

use crate::gpu::binding::storage_entry;
use crate::gpu::{Gpu, GpuError};
use crate::prefilter::prefilter_cpu;
use crate::render::iso::{self as render, valid_box, RenderOptions};
use crate::verify::{random_volume, Rng};
use crate::volume::DeviceVolume;
use crate::volume::{marschner_lobb, marschner_lobb_grad, ml_position, LatticeVolume, Volume};
use boxforge::derive::Derivation;
use boxforge::emit::{emit, Bounds, EmitOptions, EvalForm, FetchMode, Layout, Variant};

const TAG_DENSE: &str = "dense form";
const TAG_UNCHECKED: &str = "unchecked fetches";
const TAG_LINEAR: &str = "linear fetches";
use crate::references::{self, Reference};
use serde::Serialize;
use stats::{median, round_order, Ratio};
use std::collections::HashMap;
use std::time::Instant;

/// Agreement required between a reference and the generated evaluation:
/// max |generated - reference| below this fraction of the data range.
pub const REFERENCE_TOLERANCE: f64 = 1e-5;

#[derive(Clone, Debug, Serialize)]
pub struct BenchRow {
    pub filter: String,
    pub layout: String,
    pub variant: String,
    /// eval, eval_grad, central_differences, render_ml_256, ...
    pub kind: String,
    /// Median over rounds.
    pub evals_per_s: Option<f64>,
    /// Median over rounds.
    pub ms_per_frame: Option<f64>,
    /// Median of the per-round ratios (see `ratio`).
    pub ratio_to_baseline: Option<f64>,
    /// Per-round ratio statistics: median, min, max, rounds, tie.
    pub ratio: Option<Ratio>,
    pub baseline: Option<String>,
    pub fetches: Option<usize>,
    pub ops: Option<usize>,
    pub bytes: Option<usize>,
    /// Linear fetches: max |value - the exact-load baseline's value| on the
    /// timed points, as a fraction of the data range (this adapter's filtering).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub max_rel_diff_to_baseline: Option<f64>,
}

impl BenchRow {
    /// A rendering row (embedded layout, ms/frame, optional ratio to a baseline).
    pub fn render(
        filter: &str,
        kind: &str,
        variant: String,
        ms: f64,
        ratio: Option<Ratio>,
        baseline: Option<String>,
    ) -> BenchRow {
        BenchRow {
            filter: filter.into(),
            layout: "embedded".into(),
            variant,
            kind: kind.into(),
            evals_per_s: None,
            ms_per_frame: Some(ms),
            ratio_to_baseline: ratio.map(|r| r.median),
            ratio,
            baseline,
            fetches: None,
            ops: None,
            bytes: None,
            max_rel_diff_to_baseline: None,
        }
    }
}

/// The generated evaluation timed beside a hand-written one.
#[derive(Clone, Debug, Serialize)]
pub struct ReferenceRow {
    pub filter: String,
    pub generated: String,
    pub reference: String,
    pub entry: String,
    pub citation: String,
    pub generated_fetches: usize,
    pub reference_fetches: Option<usize>,
    pub generated_ops: usize,
    pub reference_ops: usize,
    /// Medians over rounds (None when not timed).
    pub generated_evals_per_s: Option<f64>,
    pub reference_evals_per_s: Option<f64>,
    /// generated ÷ reference, per round.
    pub ratio: Option<Ratio>,
    pub points: usize,
    /// max |generated - reference| over the points.
    pub max_abs_diff: Option<f64>,
    pub data_range: f64,
    /// max_abs_diff / data_range.
    pub rel_diff: Option<f64>,
    /// The check passed (rel_diff < REFERENCE_TOLERANCE); a comparison that
    /// failed it (or was skipped) is not timed.
    pub agrees: bool,
    /// Why the comparison is invalid or was skipped.
    pub note: Option<String>,
    /// The generated eval cut after its fetches (same locate, same loads,
    /// the mean of the samples) ÷ the reference, in the same rounds: the
    /// most any evaluation with these loads could reach.
    pub loads_only_ratio: Option<Ratio>,
}

/// The generated `<name>_eval` cut after its last fetch, returning the mean
/// of the fetched samples as `<name>_loads_only`: the same point location,
/// addressing and loads with none of the arithmetic after them. None when
/// the body has no fetch lines of the form `let f = <name>_fetch...`.
pub fn loads_only(module: &str, name: &str) -> Option<String> {
    let start = module.find(&format!("fn {name}_eval(p: "))?;
    let open = start + module[start..].find('{')? + 1;
    let end = open + module[open..].find("\n}\n")?;
    let lines: Vec<&str> = module[open..end].lines().collect();
    let call = format!("{name}_fetch");
    let last = lines.iter().rposition(|l| l.contains(&call))?;
    let fetched: Vec<&str> = lines[..=last]
        .iter()
        .filter(|l| l.contains(&call))
        .filter_map(|l| l.trim().strip_prefix("let ")?.split(' ').next())
        .collect();
    if fetched.is_empty() {
        return None;
    }
    Some(format!(
        "fn {name}_loads_only(p: vec3<f32>) -> f32 {{\n{}\n    return ({}) * {:?};\n}}\n",
        lines[..=last].join("\n"),
        fetched.join(" + "),
        1.0f32 / fetched.len() as f32
    ))
}

#[derive(Clone, Debug, Serialize)]
pub struct QualityRow {
    pub filter: String,
    pub lattice: String,
    pub samples: usize,
    pub budget: String,
    pub prefiltered: bool,
    pub rms_error: f64,
    pub max_error: f64,
    /// Mean angle (degrees) between the spline's analytic gradient and the
    /// analytic Marschner-Lobb gradient, where |grad| is not tiny.
    pub gradient_angle_deg: f64,
}

#[derive(Clone, Debug, Serialize)]
pub struct ConvergenceRow {
    pub filter: String,
    pub approximation_order: usize,
    pub edges: Vec<usize>,
    pub rms_errors: Vec<f64>,
    /// Order estimated from the last two resolutions.
    pub measured_order: f64,
}

#[derive(Clone, Debug, Serialize)]
pub struct BenchReport {
    pub machine: String,
    pub adapter: String,
    pub timing: String,
    /// Interleaved timing rounds per comparison.
    pub rounds: usize,
    /// Generated vs hand-written (built-in references and --wgsl).
    pub references: Vec<ReferenceRow>,
    pub rows: Vec<BenchRow>,
    pub gradient: Vec<GradientRow>,
    pub quality: Vec<QualityRow>,
    pub convergence: Vec<ConvergenceRow>,
    /// False in the snapshots [`run_with`] hands out while it measures.
    pub complete: bool,
}

#[derive(Clone, Debug, Serialize)]
pub struct GradientRow {
    pub filter: String,
    pub analytic_evals_per_s: f64,
    pub central_evals_per_s: f64,
    /// Median of the per-round ratios.
    pub speedup: f64,
    pub speedup_ratio: Ratio,
    pub analytic_angle_deg: f64,
    pub central_angle_deg: f64,
}

#[derive(Clone, Debug)]
pub struct BenchOptions {
    pub filters: Vec<String>,
    /// Points per throughput dispatch.
    pub points: usize,
    /// Interleaved timing rounds per comparison (after one warm-up each).
    pub runs: usize,
    pub naive: bool,
    /// Filters whose naive variant is measured (its shaders compile slowly
    /// on lavapipe: minutes for the large stencils).
    pub naive_filters: Vec<String>,
    pub render_sizes: Vec<u32>,
    pub mni: Option<String>,
    pub quality: bool,
    /// Time the built-in hand-written references (runtime/references/).
    pub references: bool,
    pub external: Option<External>,
}

#[derive(Clone, Debug)]
pub struct External {
    pub wgsl: String,
    pub entry: String,
    pub like: String,
}

impl BenchOptions {
    /// Only the external shader against its generated module (what
    /// `bench --wgsl F --entry E --like L` times unless asked for more).
    pub fn external_only(external: External) -> BenchOptions {
        BenchOptions {
            filters: vec![],
            naive: false,
            naive_filters: vec![],
            render_sizes: vec![],
            mni: None,
            quality: false,
            references: false,
            external: Some(external),
            ..BenchOptions::full()
        }
    }

    pub fn full() -> BenchOptions {
        BenchOptions {
            filters: ["cc_trilinear", "cc_tricubic", "bcc_linear", "bcc7", "bcc8", "bcc12", "fcc6"]
                .map(String::from)
                .to_vec(),
            points: 1 << 18,
            runs: 7,
            naive: true,
            naive_filters: ["bcc_linear", "bcc7", "fcc6"].map(String::from).to_vec(),
            render_sizes: vec![256, 512],
            mni: crate::scene::data_file("mni152_t1_1mm.nii.gz").map(|p| p.display().to_string()),
            quality: true,
            references: true,
            external: None,
        }
    }
    /// Seconds-long version for CI (numbers are not meaningful).
    pub fn smoke() -> BenchOptions {
        BenchOptions {
            filters: vec!["bcc_linear".into()],
            points: 4096,
            runs: 3,
            naive: true,
            naive_filters: vec!["bcc_linear".into()],
            render_sizes: vec![32],
            mni: None,
            quality: true,
            // Minutes of cache builds and DVR frames: not in a smoke run.
            references: false,
            external: None,
        }
    }
}

/// A throughput kernel: evaluates `call` (an expression of p) at every point;
/// its buffers live in bind group `group`.
fn kernel(call: &str, group: u32) -> String {
    format!(
        "
@group({group}) @binding(0) var<storage, read> bx_points: array<vec4<f32>>;
@group({group}) @binding(1) var<storage, read_write> bx_out: array<vec4<f32>>;

@compute @workgroup_size(64)
fn bench_main(@builtin(global_invocation_id) gid: vec3<u32>) {{
    let i = gid.x + gid.y * 65535u * 64u;
    if (i >= arrayLength(&bx_points)) {{
        return;
    }}
    let p = bx_points[i].xyz;
    bx_out[i] = {call};
}}
"
    )
}

/// A throughput program: the generated `module`, `extra` WGSL (a
/// reference), and a `bench_main` kernel writing `call` (a vec4 expression
/// of `p`) at every point, for [`Job::new`]. The kernel's buffers go to
/// group 2 when the extra code declares the `ref_linear` sampler (group 1).
pub fn program(module: &str, extra: &str, call: &str) -> String {
    let group = if references::uses_sampler(extra) { 2 } else { 1 };
    format!("{module}\n{extra}\n{}", kernel(call, group))
}

/// Central differences from 6 extra evaluations (h = 1e-2 cell).
fn central_call(name: &str) -> String {
    format!(
        "vec4<f32>({n}_eval(p), ({n}_eval(p + vec3<f32>(0.01, 0.0, 0.0)) - {n}_eval(p - vec3<f32>(0.01, 0.0, 0.0))) * 50.0, ({n}_eval(p + vec3<f32>(0.0, 0.01, 0.0)) - {n}_eval(p - vec3<f32>(0.0, 0.01, 0.0))) * 50.0, ({n}_eval(p + vec3<f32>(0.0, 0.0, 0.01)) - {n}_eval(p - vec3<f32>(0.0, 0.0, 0.01))) * 50.0)",
        n = name
    )
}

/// Does this device filter R32Float textures (wgpu::Features::FLOAT32_FILTERABLE)?
pub fn can_filter_f32(gpu: &Gpu) -> bool {
    gpu.device.features().contains(wgpu::Features::FLOAT32_FILTERABLE)
}

/// A compiled throughput kernel with its buffers, ready to dispatch.
pub struct Job {
    pipeline: wgpu::ComputePipeline,
    groups: Vec<wgpu::BindGroup>,
    out: wgpu::Buffer,
    n: usize,
    dispatch: (u32, u32),
    queries: Option<(wgpu::QuerySet, wgpu::Buffer)>,
}

impl Job {
    /// Compiles `source` (which has `bench_main`) over the points. A source
    /// declaring `ref_linear` gets a linear clamp-to-edge sampler in group 1
    /// and the volume bound as a filterable texture.
    pub fn new(gpu: &Gpu, source: &str, label: &str, dv: &DeviceVolume, points: &[[f32; 4]]) -> Result<Job, GpuError> {
        let sampled = references::uses_sampler(source);
        if sampled && !can_filter_f32(gpu) {
            return Err(GpuError::Runtime(format!(
                "{label} filters an R32Float texture, but the adapter lacks FLOAT32_FILTERABLE"
            )));
        }
        if sampled && dv.layout != Layout::Embedded {
            return Err(GpuError::Runtime(format!("{label}: hardware filtering needs the embedded layout")));
        }
        let shader = gpu.compile(label, source)?;
        let dev = &gpu.device;
        let mut entries0 = dv.layout_entries(0, wgpu::ShaderStages::COMPUTE);
        if sampled {
            for e in entries0.iter_mut() {
                if let wgpu::BindingType::Texture { sample_type, .. } = &mut e.ty {
                    *sample_type = wgpu::TextureSampleType::Float { filterable: true };
                }
            }
        }
        let bgl0 = dev.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor { label: None, entries: &entries0 });
        let bgl_sampler = dev.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: None,
            entries: &[wgpu::BindGroupLayoutEntry {
                binding: 0,
                visibility: wgpu::ShaderStages::COMPUTE,
                ty: wgpu::BindingType::Sampler(wgpu::SamplerBindingType::Filtering),
                count: None,
            }],
        });
        let bgl_io = dev.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: None,
            entries: &[storage_entry(0, true), storage_entry(1, false)],
        });
        let layouts: Vec<&wgpu::BindGroupLayout> =
            if sampled { vec![&bgl0, &bgl_sampler, &bgl_io] } else { vec![&bgl0, &bgl_io] };
        let pipeline = gpu.pipeline(label, &shader, &layouts, "bench_main")?;
        let n = points.len();
        let pts = gpu.storage_buffer("points", bytemuck::cast_slice(points), false);
        let out = gpu.storage_buffer("out", &vec![0u8; n * 16], true);
        let bg0 = dev.create_bind_group(&wgpu::BindGroupDescriptor {
            label: None,
            layout: &bgl0,
            entries: &dv.bind_entries(0),
        });
        let bg_io = dev.create_bind_group(&wgpu::BindGroupDescriptor {
            label: None,
            layout: &bgl_io,
            entries: &[
                wgpu::BindGroupEntry { binding: 0, resource: pts.as_entire_binding() },
                wgpu::BindGroupEntry { binding: 1, resource: out.as_entire_binding() },
            ],
        });
        let groups = if sampled {
            let sampler = crate::gpu::binding::linear_sampler(gpu, "ref_linear");
            let bg_s = dev.create_bind_group(&wgpu::BindGroupDescriptor {
                label: None,
                layout: &bgl_sampler,
                entries: &[wgpu::BindGroupEntry { binding: 0, resource: wgpu::BindingResource::Sampler(&sampler) }],
            });
            vec![bg0, bg_s, bg_io]
        } else {
            vec![bg0, bg_io]
        };
        let wg = n.div_ceil(64) as u32;
        // GPU time from timestamp queries when the adapter has them, else wall
        // time around submit + wait.
        let queries = gpu.timestamps.then(|| {
            let set = dev.create_query_set(&wgpu::QuerySetDescriptor {
                label: None,
                ty: wgpu::QueryType::Timestamp,
                count: 2,
            });
            let resolve = dev.create_buffer(&wgpu::BufferDescriptor {
                label: Some("timestamps"),
                size: 16,
                usage: wgpu::BufferUsages::QUERY_RESOLVE | wgpu::BufferUsages::COPY_SRC,
                mapped_at_creation: false,
            });
            (set, resolve)
        });
        Ok(Job { pipeline, groups, out, n, dispatch: (wg.min(65535), wg.div_ceil(65535)), queries })
    }

    /// Seconds for one dispatch.
    pub fn time(&self, gpu: &Gpu) -> Result<f64, GpuError> {
        let dev = &gpu.device;
        let start = Instant::now();
        let mut enc = dev.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: None });
        {
            let timestamp_writes = self.queries.as_ref().map(|(set, _)| wgpu::ComputePassTimestampWrites {
                query_set: set,
                beginning_of_pass_write_index: Some(0),
                end_of_pass_write_index: Some(1),
            });
            let mut pass = enc.begin_compute_pass(&wgpu::ComputePassDescriptor { label: None, timestamp_writes });
            pass.set_pipeline(&self.pipeline);
            for (i, g) in self.groups.iter().enumerate() {
                pass.set_bind_group(i as u32, g, &[]);
            }
            pass.dispatch_workgroups(self.dispatch.0, self.dispatch.1, 1);
        }
        if let Some((set, resolve)) = &self.queries {
            enc.resolve_query_set(set, 0..2, resolve, 0);
        }
        gpu.queue.submit([enc.finish()]);
        gpu.wait()?;
        let wall = start.elapsed().as_secs_f64();
        if let Some((_, resolve)) = &self.queries {
            let ts: Vec<u64> = bytemuck::cast_slice(&gpu.read_buffer(resolve)?).to_vec();
            let gpu_s = ts[1].saturating_sub(ts[0]) as f64 * gpu.queue.get_timestamp_period() as f64 * 1e-9;
            if gpu_s > 0.0 {
                return Ok(gpu_s);
            }
        }
        Ok(wall)
    }

    /// The outputs of the last dispatch.
    pub fn outputs(&self, gpu: &Gpu) -> Result<Vec<[f32; 4]>, GpuError> {
        Ok(bytemuck::cast_slice(&gpu.read_buffer(&self.out)?).to_vec())
    }

    pub fn points(&self) -> usize {
        self.n
    }
}

/// Interleaved rounds: one warm-up dispatch per job (it includes pipeline
/// compilation on lavapipe), then `rounds` rounds timing every job once, the
/// order rotated each round. A job whose second dispatch takes under 50 ms is
/// timed as the fastest of 3 back-to-back dispatches in its turn (short
/// dispatches are the ones other processes on the machine disturb most).
/// Returns evals/s per job per round.
pub fn timed_rounds(gpu: &Gpu, jobs: &[&Job], rounds: usize) -> Result<Vec<Vec<f64>>, GpuError> {
    let mut reps = Vec::with_capacity(jobs.len());
    for j in jobs {
        j.time(gpu)?;
        reps.push(if j.time(gpu)? < 0.05 { 3 } else { 1 });
    }
    let mut rates = vec![Vec::with_capacity(rounds); jobs.len()];
    for r in 0..rounds.max(1) {
        for k in round_order(jobs.len(), r) {
            let mut s = f64::INFINITY;
            for _ in 0..reps[k] {
                s = s.min(jobs[k].time(gpu)?);
            }
            rates[k].push(jobs[k].n as f64 / s);
        }
    }
    Ok(rates)
}

fn angle_deg(a: [f64; 3], b: [f64; 3]) -> Option<f64> {
    let na = (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt();
    let nb = (b[0] * b[0] + b[1] * b[1] + b[2] * b[2]).sqrt();
    if na < 1e-9 || nb < 1e-9 {
        return None;
    }
    let c = ((a[0] * b[0] + a[1] * b[1] + a[2] * b[2]) / (na * nb)).clamp(-1.0, 1.0);
    Some(c.acos().to_degrees())
}

fn derive(name: &str) -> Result<Derivation, String> {
    let f = boxforge::spec::resolve(name).map_err(|e| e.to_string())?;
    Derivation::new(&f).map_err(|e| e.to_string())
}

fn points_in(d: &Derivation, vol: &LatticeVolume, n: usize, seed: u64) -> Vec<[f32; 4]> {
    let (lo, hi) = valid_box(d, vol);
    let mut rng = Rng(seed);
    (0..n)
        .map(|_| {
            let mut p = [0f32; 4];
            for i in 0..3 {
                p[i] = lo[i] + rng.next_f64() as f32 * (hi[i] - lo[i]);
            }
            p
        })
        .collect()
}

/// Mean angle error of gradients (in lattice coordinates) against the
/// analytic ML gradient (chain rule through the lattice-to-[-1,1] map).
fn ml_angle(vol: &LatticeVolume, pts: &[[f32; 4]], grads: &[[f32; 4]]) -> f64 {
    let (mut sum, mut n) = (0.0, 0);
    for (p, g) in pts.iter().zip(grads) {
        let x = ml_position(vol.dims, [p[0] as f64, p[1] as f64, p[2] as f64]);
        let ga = marschner_lobb_grad(x);
        // d/dj = d/dx * 2/(n-1): positive per-axis scale, so rescale.
        let s: Vec<f64> = (0..3).map(|i| 2.0 / (vol.dims[i] as f64 - 1.0)).collect();
        let ga = [ga[0] * s[0], ga[1] * s[1], ga[2] * s[2]];
        if let Some(a) = angle_deg([g[1] as f64, g[2] as f64, g[3] as f64], ga) {
            sum += a;
            n += 1;
        }
    }
    sum / n.max(1) as f64
}

/// One throughput contender of a filter.
struct Contender {
    layout: Layout,
    variant: Variant,
    /// None: the module as generated by default (chosen form, clamped
    /// fetches); Some: the dense form or unchecked bounds, compared with it.
    tag: Option<&'static str>,
    kind: &'static str,
    fetches: usize,
    ops: usize,
    bytes: usize,
    job: Job,
}

/// Checks every input of a run (filters, the MNI file, an external shader)
/// before the first measurement, so a bad one fails in a second instead of
/// after minutes of timing. [`run`] calls it; the CLI calls it before it
/// even opens a device.
pub fn check_inputs(o: &BenchOptions) -> Result<(), String> {
    for name in &o.filters {
        derive(name)?;
    }
    if let Some(path) = &o.mni {
        if !std::path::Path::new(path).is_file() {
            return Err(format!(
                "the MNI head {path} is missing: run from the repository root (it ships data/), or leave it out"
            ));
        }
    }
    if let Some(ext) = &o.external {
        std::fs::read_to_string(&ext.wgsl)
            .map_err(|x| format!("cannot read --wgsl {}: {x} (check the path)", ext.wgsl))?;
        derive(&ext.like)?;
    }
    Ok(())
}

pub fn run(gpu: &Gpu, o: &BenchOptions, progress: &dyn Fn(&str)) -> Result<BenchReport, String> {
    run_with(gpu, o, progress, &|_| {})
}

/// [`run`], handing `partial` a snapshot of everything measured so far after
/// each filter and section, so an interrupted run keeps what it measured
/// (the CLI rewrites `--markdown` from each snapshot).
pub fn run_with(
    gpu: &Gpu,
    o: &BenchOptions,
    progress: &dyn Fn(&str),
    partial: &dyn Fn(&BenchReport),
) -> Result<BenchReport, String> {
    check_inputs(o)?;
    let rounds_for_snapshot = o.runs.max(1);
    let snapshot = |rows: &[BenchRow], gradient: &[GradientRow], references: &[ReferenceRow]| {
        partial(&BenchReport {
            machine: machine_info(),
            adapter: gpu.describe(),
            timing: "partial run: see the complete report for the timing method".into(),
            rounds: rounds_for_snapshot,
            references: references.to_vec(),
            rows: rows.to_vec(),
            gradient: gradient.to_vec(),
            quality: vec![],
            convergence: vec![],
            complete: false,
        })
    };
    let mut rows = Vec::new();
    let mut gradient = Vec::new();
    let e = |x: GpuError| x.to_string();
    let rounds = o.runs.max(1);
    // Embedded fast jobs kept for the cross-filter comparison (bcc7 vs bcc8).
    let pair = ("bcc7", "bcc8");
    let mut kept: HashMap<(String, &'static str), Job> = HashMap::new();
    for name in &o.filters {
        let d = derive(name)?;
        if d.facts.dim != 3 {
            continue;
        }
        let vol = random_volume(&d, 11);
        let pts = crate::verify::random_points(&d, &vol, o.points, 11);
        let mut cs: Vec<Contender> = Vec::new();
        for layout in [Layout::Embedded, Layout::Packed] {
            let dv = DeviceVolume::new(gpu, &vol, layout).map_err(e)?;
            // The naive variant runs ~1000x slower on lavapipe and its shaders
            // take minutes to compile there: time it on the embedded layout
            // with fewer points (evals/s is a rate, so the ratio stands).
            let with_naive = o.naive && o.naive_filters.contains(name) && layout == Layout::Embedded;
            let variants: &[Variant] = if with_naive { &[Variant::Fast, Variant::Naive] } else { &[Variant::Fast] };
            let mut modules: Vec<(Variant, Option<&'static str>, EmitOptions)> = variants
                .iter()
                .map(|&variant| (variant, None, EmitOptions { layout, variant, kernels: false, ..Default::default() }))
                .collect();
            if layout == Layout::Embedded {
                let base = EmitOptions { layout, kernels: false, ..Default::default() };
                let chosen = emit(&d, &base).map_err(|x| x.to_string())?.stats.form;
                if chosen != EvalForm::Dense {
                    modules.push((
                        Variant::Fast,
                        Some(TAG_DENSE),
                        EmitOptions { form: Some(EvalForm::Dense), ..base.clone() },
                    ));
                }
                modules.push((
                    Variant::Fast,
                    Some(TAG_UNCHECKED),
                    EmitOptions { bounds: Bounds::Unchecked, ..base.clone() },
                ));
                if can_filter_f32(gpu) && d.factorisation().is_some_and(|f| f.supports_linear_fetch()) {
                    modules.push((Variant::Fast, Some(TAG_LINEAR), EmitOptions { fetch: FetchMode::Linear, ..base }));
                }
            } else if can_filter_f32(gpu) {
                // Packed: pairs of each coset's samples in one filtered fetch,
                // where the stencil has pairs at all.
                let lin = boxforge::emit::linear::LinearPlan::new(&d);
                let plan = boxforge::emit::plan::Plan::new(&d);
                if lin.fetches(&plan) < plan.fetches() {
                    let opts = EmitOptions { layout, kernels: false, fetch: FetchMode::Linear, ..Default::default() };
                    modules.push((Variant::Fast, Some(TAG_LINEAR), opts));
                }
            }
            let dv_filtered = if modules.iter().any(|m| m.1 == Some(TAG_LINEAR)) {
                Some(DeviceVolume::new_filtered(gpu, &vol, layout).map_err(e)?)
            } else {
                None
            };
            for (variant, tag, opts) in modules {
                let m = emit(&d, &opts).map_err(|x| x.to_string())?;
                let dv = if tag == Some(TAG_LINEAR) { dv_filtered.as_ref().unwrap_or(&dv) } else { &dv };
                for (kind, call) in [
                    ("eval", format!("vec4<f32>({name}_eval(p), 0.0, 0.0, 0.0)")),
                    ("eval_grad", format!("{name}_eval_grad(p)")),
                ] {
                    if tag == Some(TAG_LINEAR) && layout == Layout::Packed && kind == "eval_grad" {
                        // eval_grad keeps exact loads: the same code as the exact module.
                        continue;
                    }
                    progress(&format!("{name} {} {} {kind}: compile", layout.name(), variant.name()));
                    let src = program(&m.source, "", &call);
                    let sample = if variant == Variant::Naive { &pts[..pts.len().min(8192)] } else { &pts[..] };
                    let job = Job::new(gpu, &src, &m.file_name, dv, sample).map_err(e)?;
                    cs.push(Contender {
                        layout,
                        variant,
                        tag,
                        kind,
                        fetches: m.stats.fetches_per_eval,
                        ops: if kind == "eval" { m.stats.ops_eval } else { m.stats.ops_eval_grad },
                        bytes: dv.bytes,
                        job,
                    });
                }
            }
        }
        progress(&format!("{name}: {} contenders x {rounds} interleaved rounds", cs.len()));
        let rates = timed_rounds(gpu, &cs.iter().map(|c| &c.job).collect::<Vec<_>>(), rounds).map_err(e)?;
        let find = |layout: Layout, variant: Variant, kind: &str| {
            cs.iter().position(|c| c.layout == layout && c.variant == variant && c.kind == kind && c.tag.is_none())
        };
        let range = {
            let (lo, hi) = vol.data.iter().fold((f32::INFINITY, f32::NEG_INFINITY), |(a, b), &x| (a.min(x), b.max(x)));
            (hi - lo).max(f32::MIN_POSITIVE) as f64
        };
        for (k, c) in cs.iter().enumerate() {
            // Filtered values against the exact loads on the same points.
            let linear_diff = match (c.tag, find(c.layout, Variant::Fast, c.kind)) {
                (Some(TAG_LINEAR), Some(f)) => {
                    let (a, b) = (c.job.outputs(gpu).map_err(e)?, cs[f].job.outputs(gpu).map_err(e)?);
                    Some(a.iter().zip(&b).map(|(x, y)| (x[0] as f64 - y[0] as f64).abs()).fold(0f64, f64::max) / range)
                }
                _ => None,
            };
            let (ratio, baseline) = match (c.tag, c.variant, c.layout) {
                (Some(TAG_DENSE), _, _) => (
                    find(Layout::Embedded, Variant::Fast, c.kind).map(|f| Ratio::of_rates(&rates[f], &rates[k])),
                    Some("chosen form ÷ dense form".to_string()),
                ),
                (Some(TAG_LINEAR), _, l) => (
                    find(l, Variant::Fast, c.kind).map(|f| Ratio::of_rates(&rates[k], &rates[f])),
                    Some("linear ÷ exact fetches".to_string()),
                ),
                (Some(_), _, _) => (
                    find(Layout::Embedded, Variant::Fast, c.kind).map(|f| Ratio::of_rates(&rates[k], &rates[f])),
                    Some("unchecked ÷ clamped fetches".to_string()),
                ),
                (None, v, l) => match (v, l) {
                    (Variant::Naive, _) => (
                        find(Layout::Embedded, Variant::Fast, c.kind).map(|f| Ratio::of_rates(&rates[f], &rates[k])),
                        Some("fast ÷ naive".to_string()),
                    ),
                    (Variant::Fast, Layout::Packed) => (
                        find(Layout::Embedded, Variant::Fast, c.kind).map(|f| Ratio::of_rates(&rates[k], &rates[f])),
                        Some("packed ÷ embedded".to_string()),
                    ),
                    _ => (None, None),
                },
            };
            rows.push(BenchRow {
                filter: name.clone(),
                layout: c.layout.name().into(),
                variant: match c.tag {
                    Some(t) => format!("{} ({t})", c.variant.name()),
                    None => c.variant.name().into(),
                },
                kind: c.kind.into(),
                evals_per_s: Some(median(&rates[k])),
                ms_per_frame: None,
                ratio_to_baseline: ratio.map(|r| r.median),
                ratio,
                baseline,
                fetches: Some(c.fetches),
                ops: Some(c.ops),
                bytes: Some(c.bytes),
                max_rel_diff_to_baseline: linear_diff,
            });
        }
        if name == pair.0 || name == pair.1 {
            for c in
                cs.into_iter().filter(|c| c.layout == Layout::Embedded && c.variant == Variant::Fast && c.tag.is_none())
            {
                kept.insert((name.clone(), c.kind), c.job);
            }
        }
        // Analytic gradient vs central differences, on Marschner-Lobb.
        let e3 = crate::scene::matched_edge(&d.filter.lattice, 41f64.powi(3));
        let ml = LatticeVolume::marschner_lobb(&d.filter.lattice, [e3, e3, e3]).map_err(|x| x.to_string())?;
        let dv = DeviceVolume::new(gpu, &ml, Layout::Embedded).map_err(e)?;
        let mpts = points_in(&d, &ml, o.points, 5);
        let m = emit(&d, &EmitOptions { kernels: false, ..Default::default() }).map_err(|x| x.to_string())?;
        progress(&format!("{name} analytic vs central-difference gradient"));
        let a =
            Job::new(gpu, &program(&m.source, "", &format!("{name}_eval_grad(p)")), "grad", &dv, &mpts).map_err(e)?;
        let c = Job::new(gpu, &program(&m.source, "", &central_call(name)), "central", &dv, &mpts).map_err(e)?;
        let r = timed_rounds(gpu, &[&a, &c], rounds).map_err(e)?;
        let speed = Ratio::of_rates(&r[0], &r[1]);
        let (a_out, c_out) = (a.outputs(gpu).map_err(e)?, c.outputs(gpu).map_err(e)?);
        rows.push(BenchRow {
            filter: name.clone(),
            layout: "embedded".into(),
            variant: "fast".into(),
            kind: "central_differences".into(),
            evals_per_s: Some(median(&r[1])),
            ms_per_frame: None,
            ratio_to_baseline: Some(speed.median),
            ratio: Some(speed),
            baseline: Some("analytic eval_grad ÷ central differences".into()),
            fetches: Some(m.stats.fetches_per_eval * 7),
            ops: None,
            bytes: None,
            max_rel_diff_to_baseline: None,
        });
        gradient.push(GradientRow {
            filter: name.clone(),
            analytic_evals_per_s: median(&r[0]),
            central_evals_per_s: median(&r[1]),
            speedup: speed.median,
            speedup_ratio: speed,
            analytic_angle_deg: ml_angle(&ml, &mpts, &a_out),
            central_angle_deg: ml_angle(&ml, &mpts, &c_out),
        });
        // Rendering.
        for &size in &o.render_sizes {
            progress(&format!("{name} render Marschner-Lobb {size}^2, skipping vs not, {rounds} rounds"));
            let ro = |skip| RenderOptions { width: size, height: size, skip, frames: 1, ..RenderOptions::default() };
            let ms = render_rounds(rounds, |skip| {
                render::render(gpu, &d, &ml, Layout::Embedded, &ro(skip)).map(|f| f.ms_per_frame).map_err(e)
            })?;
            rows.extend(render_rows(name, &format!("render_ml_{size}"), &ms));
        }
        rows.extend(hit::rows(gpu, &d, &ml, &o.render_sizes, rounds, progress)?);
        snapshot(&rows, &gradient, &[]);
    }
    // bcc7 against bcc8.
    for kind in ["eval", "eval_grad"] {
        if let (Some(a), Some(b)) = (kept.get(&(pair.0.to_string(), kind)), kept.get(&(pair.1.to_string(), kind))) {
            progress(&format!("{} vs {} {kind}, {rounds} rounds", pair.0, pair.1));
            let r = timed_rounds(gpu, &[a, b], rounds).map_err(e)?;
            let ratio = Ratio::of_rates(&r[0], &r[1]);
            rows.push(BenchRow {
                filter: pair.0.into(),
                layout: "embedded".into(),
                variant: "fast".into(),
                kind: format!("{kind}_vs_{}", pair.1),
                evals_per_s: Some(median(&r[0])),
                ms_per_frame: None,
                ratio_to_baseline: Some(ratio.median),
                ratio: Some(ratio),
                baseline: Some(format!("{} ÷ {}", pair.0, pair.1)),
                fetches: None,
                ops: None,
                bytes: None,
                max_rel_diff_to_baseline: None,
            });
        }
    }
    drop(kept);
    // Generated vs hand-written.
    let mut refs: Vec<Reference> = if o.references { references::builtin() } else { vec![] };
    if let Some(ext) = &o.external {
        let source = std::fs::read_to_string(&ext.wgsl).map_err(|x| format!("cannot read {}: {x}", ext.wgsl))?;
        refs.push(Reference {
            name: format!("external {}", ext.wgsl),
            like: ext.like.clone(),
            entry: ext.entry.clone(),
            citation: format!("--wgsl {}", ext.wgsl),
            source,
        });
    }
    let mut reference_rows = Vec::new();
    for r in &refs {
        progress(&format!("{} vs {}_eval, {rounds} rounds", r.name, r.like));
        let row = compare_reference(gpu, r, o.points, rounds)?;
        if !row.agrees {
            progress(&format!(
                "WARNING: {} vs {}_eval is INVALID: {}",
                r.name,
                r.like,
                row.note.clone().unwrap_or_default()
            ));
        }
        reference_rows.push(row);
        snapshot(&rows, &gradient, &reference_rows);
    }
    // The MNI head.
    if let Some(path) = &o.mni {
        let head = Volume::load_nifti(std::path::Path::new(path)).map_err(|x| x.to_string())?;
        for name in o.filters.iter().filter(|n| ["bcc7", "bcc8", "fcc6", "cc_tricubic"].contains(&n.as_str())) {
            let d = derive(name)?;
            let v = crate::scene::from_cartesian(&head, &d.filter.lattice, crate::scene::Conversion::Resample)
                .map_err(|x| x.to_string())?;
            for &size in &o.render_sizes {
                progress(&format!("{name} render MNI {size}^2, skipping vs not, {rounds} rounds"));
                let ro = |skip| RenderOptions {
                    width: size,
                    height: size,
                    iso: 90.0,
                    step: 0.5,
                    azimuth: 200.0,
                    elevation: 15.0,
                    skip,
                    frames: 1,
                    ..RenderOptions::default()
                };
                let ms = render_rounds(rounds, |skip| {
                    render::render(gpu, &d, &v, Layout::Embedded, &ro(skip)).map(|f| f.ms_per_frame).map_err(e)
                })?;
                rows.extend(render_rows(name, &format!("render_mni_{size}"), &ms));
            }
            snapshot(&rows, &gradient, &reference_rows);
        }
    }
    // Direct volume rendering: skipping and pre-integration.
    rows.extend(dvr::rows(gpu, o, rounds, progress)?);
    snapshot(&rows, &gradient, &reference_rows);
    let (quality, convergence) = if o.quality { quality(gpu, o, progress)? } else { (vec![], vec![]) };
    let clock = if gpu.timestamps {
        "GPU time of one dispatch from timestamp queries (throughput rows), wall time around submit + wait of one frame after a warm-up frame (render rows)"
    } else {
        "wall time around submit + wait of one dispatch (throughput rows) or one frame after a warm-up frame (render rows)"
    };
    Ok(BenchReport {
        machine: machine_info(),
        adapter: gpu.describe(),
        timing: format!(
            "{clock}; every comparison in {rounds} interleaved rounds after one warm-up each (each contender once per round, the order rotated each round; a dispatch under 50 ms counts as the fastest of 3 back-to-back); rates are medians over rounds, ratios the median of the per-round ratios with [min..max] over rounds, a tie when that range spans 1"
        ),
        rounds,
        references: reference_rows,
        rows,
        gradient,
        quality,
        convergence,
        complete: true,
    })
}

/// Render frames with and without skipping in interleaved rounds: (skip ms, no-skip ms) per round.
fn render_rounds(rounds: usize, mut frame: impl FnMut(bool) -> Result<f64, String>) -> Result<Vec<(f64, f64)>, String> {
    let mut out = Vec::new();
    for r in 0..rounds.max(1) {
        let mut t = [0.0; 2];
        for k in round_order(2, r) {
            t[k] = frame(k == 0)?;
        }
        out.push((t[0], t[1]));
    }
    Ok(out)
}

fn render_rows(name: &str, kind: &str, ms: &[(f64, f64)]) -> Vec<BenchRow> {
    let skip: Vec<f64> = ms.iter().map(|m| m.0).collect();
    let noskip: Vec<f64> = ms.iter().map(|m| m.1).collect();
    let ratio = Ratio::of_rates(&noskip, &skip);
    let row = |variant: &str, ms: f64, ratio: Option<Ratio>| {
        BenchRow::render(name, kind, variant.into(), ms, ratio, ratio.map(|_| "no skipping ÷ skipping (time)".into()))
    };
    vec![row("fast, skipping", median(&skip), None), row("fast, no skipping", median(&noskip), Some(ratio))]
}

/// Times a hand-written evaluation beside the generated `<like>_eval` on the
/// same random points of a random volume, after checking that they agree.
pub fn compare_reference(gpu: &Gpu, r: &Reference, points: usize, rounds: usize) -> Result<ReferenceRow, String> {
    let e = |x: GpuError| x.to_string();
    let d = derive(&r.like)?;
    let name = d.filter.name.clone();
    // A 64^3-ish volume of random data (at least the support-sized one).
    let mut vol = random_volume(&d, 11);
    if vol.dims[0] < 64 {
        let n = 64usize;
        let mut rng = Rng(17);
        let mut data = vec![0f32; n * n * n];
        for k in 0..n {
            for j in 0..n {
                for i in 0..n {
                    if d.filter.lattice.contains(&[i as i64, j as i64, k as i64]) {
                        data[i + n * (j + n * k)] = rng.next_f64() as f32;
                    }
                }
            }
        }
        vol = LatticeVolume { lattice: d.filter.lattice.clone(), dims: [n, n, n], data };
    }
    let pts = crate::verify::random_points(&d, &vol, points, 23);
    let (lo, hi) = vol.data.iter().fold((f32::INFINITY, f32::NEG_INFINITY), |(a, b), &x| (a.min(x), b.max(x)));
    let data_range = (hi - lo).max(f32::MIN_POSITIVE) as f64;
    // A reference that uses hardware filtering meets the generated module
    // with linear fetches where the filter allows them (same fetch budget).
    let linear = references::uses_sampler(&r.source)
        && can_filter_f32(gpu)
        && d.factorisation().is_some_and(|f| f.supports_linear_fetch());
    let fetch = if linear { FetchMode::Linear } else { FetchMode::Exact };
    let m = emit(&d, &EmitOptions { kernels: false, fetch, ..Default::default() }).map_err(|x| x.to_string())?;
    let module_with_ref = format!("{}\n{}", m.source, r.source);
    let reference_ops = references::ops(&module_with_ref, &r.source, &r.entry);
    let mut row = ReferenceRow {
        filter: name.clone(),
        generated: if linear { format!("{name}_eval (linear fetches)") } else { format!("{name}_eval") },
        reference: r.name.clone(),
        entry: r.entry.clone(),
        citation: r.citation.clone(),
        generated_fetches: m.stats.fetches_per_eval,
        reference_fetches: references::fetches(&module_with_ref, &r.source, &r.entry),
        generated_ops: m.stats.ops_eval,
        reference_ops,
        generated_evals_per_s: None,
        reference_evals_per_s: None,
        ratio: None,
        points: pts.len(),
        max_abs_diff: None,
        data_range,
        rel_diff: None,
        agrees: false,
        note: None,
        loads_only_ratio: None,
    };
    if references::uses_sampler(&r.source) && !can_filter_f32(gpu) {
        row.note = Some(format!(
            "skipped: {} needs hardware filtering of R32Float, and this adapter lacks FLOAT32_FILTERABLE",
            r.name
        ));
        return Ok(row);
    }
    let dv = if linear {
        DeviceVolume::new_filtered(gpu, &vol, Layout::Embedded)
    } else {
        DeviceVolume::new(gpu, &vol, Layout::Embedded)
    }
    .map_err(e)?;
    let ours = program(&m.source, "", &format!("vec4<f32>({name}_eval(p), 0.0, 0.0, 0.0)"));
    let theirs = program(&m.source, &r.source, &format!("vec4<f32>({}(p), 0.0, 0.0, 0.0)", r.entry));
    let a = Job::new(gpu, &ours, &m.file_name, &dv, &pts).map_err(e)?;
    let b = Job::new(gpu, &theirs, &r.name, &dv, &pts).map_err(e)?;
    // The check first: a reference that disagrees is not timed.
    a.time(gpu).map_err(e)?;
    b.time(gpu).map_err(e)?;
    let (va, vb) = (a.outputs(gpu).map_err(e)?, b.outputs(gpu).map_err(e)?);
    let max_diff = va.iter().zip(&vb).map(|(x, y)| (x[0] as f64 - y[0] as f64).abs()).fold(0f64, |m, x| {
        if x.is_nan() || m.is_nan() {
            f64::NAN
        } else {
            m.max(x)
        }
    });
    let rel = max_diff / data_range;
    row.max_abs_diff = Some(max_diff);
    row.rel_diff = Some(rel);
    row.agrees = rel < REFERENCE_TOLERANCE;
    if !row.agrees {
        row.note = Some(format!(
            "INVALID: max |generated - reference| = {max_diff:.3e} = {rel:.2e} of the data range (tolerance {REFERENCE_TOLERANCE:.0e}); not timed"
        ));
        return Ok(row);
    }
    // The ceiling of exact loads: the generated eval cut after its fetches.
    let ceiling = match loads_only(&m.source, &name) {
        Some(f) if !linear => {
            let src = program(&m.source, &f, &format!("vec4<f32>({name}_loads_only(p), 0.0, 0.0, 0.0)"));
            Some(Job::new(gpu, &src, &format!("{name} loads only"), &dv, &pts).map_err(e)?)
        }
        _ => None,
    };
    let mut jobs = vec![&a, &b];
    jobs.extend(ceiling.as_ref());
    let rates = timed_rounds(gpu, &jobs, rounds).map_err(e)?;
    row.generated_evals_per_s = Some(median(&rates[0]));
    row.reference_evals_per_s = Some(median(&rates[1]));
    row.ratio = Some(Ratio::of_rates(&rates[0], &rates[1]));
    row.loads_only_ratio = rates.get(2).map(|c| Ratio::of_rates(c, &rates[1]));
    Ok(row)
}

fn quality(
    gpu: &Gpu,
    o: &BenchOptions,
    progress: &dyn Fn(&str),
) -> Result<(Vec<QualityRow>, Vec<ConvergenceRow>), String> {
    let mut q = Vec::new();
    let mut conv = Vec::new();
    let cc_budget = 41f64.powi(3);
    let npts = o.points.min(100_000);
    for name in &o.filters {
        let d = derive(name)?;
        if d.facts.dim != 3 {
            continue;
        }
        let det = d.filter.lattice.det();
        let budgets: Vec<(String, f64)> = if det == 1 {
            vec![("41^3".into(), cc_budget)]
        } else {
            vec![("same as 41^3".into(), cc_budget), ("29.3% fewer".into(), cc_budget * 0.707)]
        };
        for (label, budget) in budgets {
            let edge = crate::scene::matched_edge(&d.filter.lattice, budget);
            let ml = LatticeVolume::marschner_lobb(&d.filter.lattice, [edge, edge, edge]).map_err(|x| x.to_string())?;
            for pre in [false, true] {
                progress(&format!("{name} quality {label} prefilter={pre}"));
                let v = if pre { prefilter_cpu(&d, &ml) } else { ml.clone() };
                let pts = points_in(&d, &v, npts, 9);
                let dv = DeviceVolume::new(gpu, &v, Layout::Embedded).map_err(|x| x.to_string())?;
                let (_, g) = crate::verify::gpu_eval(gpu, &d, &dv, Variant::Fast, &pts).map_err(|x| x.to_string())?;
                let (mut sum, mut max) = (0.0, 0f64);
                for (p, gv) in pts.iter().zip(&g) {
                    let x = ml_position(v.dims, [p[0] as f64, p[1] as f64, p[2] as f64]);
                    let err = gv[0] as f64 - marschner_lobb(x);
                    sum += err * err;
                    max = max.max(err.abs());
                }
                q.push(QualityRow {
                    filter: name.clone(),
                    lattice: d.filter.lattice.name.clone(),
                    samples: v.samples(),
                    budget: label.clone(),
                    prefiltered: pre,
                    rms_error: (sum / pts.len() as f64).sqrt(),
                    max_error: max,
                    gradient_angle_deg: ml_angle(&v, &pts, &g),
                });
            }
        }
        progress(&format!("{name} convergence"));
        let edges: Vec<usize> = vec![16, 24, 32];
        let errs = smooth_convergence(gpu, &d, &edges)?;
        let hs: Vec<f64> = edges.iter().map(|&n| 1.0 / n as f64).collect();
        let k = errs.len() - 1;
        let order = (errs[k - 1] / errs[k]).ln() / (hs[k - 1] / hs[k]).ln();
        conv.push(ConvergenceRow {
            filter: name.clone(),
            approximation_order: d.facts.approximation_order,
            edges,
            rms_errors: errs,
            measured_order: order,
        });
    }
    Ok((q, conv))
}

/// evals/s of the default module's `<f>_eval` on `dv` at `points`, one rate
/// per round (`rounds` timed dispatches after a warm-up).
///
/// # Errors
///
/// Emission or device errors, as a message.
pub fn eval_rates(
    gpu: &Gpu,
    d: &Derivation,
    dv: &DeviceVolume,
    points: &[[f32; 4]],
    rounds: usize,
) -> Result<Vec<f64>, String> {
    let name = &d.filter.name;
    let m =
        emit(d, &EmitOptions { layout: dv.layout, kernels: false, ..Default::default() }).map_err(|e| e.to_string())?;
    let src = program(&m.source, "", &format!("vec4<f32>({name}_eval(p), 0.0, 0.0, 0.0)"));
    let job = Job::new(gpu, &src, &m.file_name, dv, points).map_err(|e| e.to_string())?;
    let rates = timed_rounds(gpu, &[&job], rounds.max(1)).map_err(|e| e.to_string())?;
    Ok(rates.into_iter().next().unwrap_or_default())
}

/// RMS error of the prefiltered spline against the smooth signal
/// f = cos(1.5x) cos(y) cos(0.5z) on [-1,1]^3 sampled with n cells per unit
/// length 2, for each n in `edges` (4000 points in the central half): the
/// convergence curve whose slope is the measured approximation order.
///
/// # Errors
///
/// Device errors, as a message.
pub fn smooth_convergence(gpu: &Gpu, d: &Derivation, edges: &[usize]) -> Result<Vec<f64>, String> {
    let smooth = |x: [f64; 3]| (1.5 * x[0]).cos() * x[1].cos() * (0.5 * x[2]).cos();
    let mut errs = Vec::new();
    for &n in edges {
        let r = crate::verify::support_radius(d);
        let dims = [n + 2 * r + 2; 3];
        // Map the inner n cells onto [-1,1]: x = -1 + 2 (j - r - 1) / n.
        let off = (r + 1) as f64;
        let to_x = |j: [f64; 3]| [0, 1, 2].map(|i| -1.0 + 2.0 * (j[i] - off) / n as f64);
        let mut v =
            LatticeVolume { lattice: d.filter.lattice.clone(), dims, data: vec![0.0; dims[0] * dims[1] * dims[2]] };
        for z in 0..dims[2] {
            for y in 0..dims[1] {
                for x in 0..dims[0] {
                    if v.is_lattice(&[x as i64, y as i64, z as i64]) {
                        v.data[x + dims[0] * (y + dims[1] * z)] = smooth(to_x([x as f64, y as f64, z as f64])) as f32;
                    }
                }
            }
        }
        let v = prefilter_cpu(d, &v);
        let mut rng = Rng(3);
        let pts: Vec<[f32; 4]> = (0..4000)
            .map(|_| {
                let mut p = [0f32; 4];
                for pi in p.iter_mut().take(3) {
                    *pi = (off + 0.25 * n as f64 + rng.next_f64() * 0.5 * n as f64) as f32;
                }
                p
            })
            .collect();
        let dv = DeviceVolume::new(gpu, &v, Layout::Embedded).map_err(|x| x.to_string())?;
        let (vals, _) = crate::verify::gpu_eval(gpu, d, &dv, Variant::Fast, &pts).map_err(|x| x.to_string())?;
        let rms = (pts
            .iter()
            .zip(&vals)
            .map(|(p, val)| {
                let e = *val as f64 - smooth(to_x([p[0] as f64, p[1] as f64, p[2] as f64]));
                e * e
            })
            .sum::<f64>()
            / pts.len() as f64)
            .sqrt();
        errs.push(rms);
    }
    Ok(errs)
}

/// CPU model, cores, OS and architecture.
pub fn machine_description() -> String {
    machine_info()
}

fn machine_info() -> String {
    let cpu = std::fs::read_to_string("/proc/cpuinfo")
        .ok()
        .and_then(|s| {
            s.lines()
                .find(|l| l.starts_with("model name"))
                .map(|l| l.split(':').nth(1).unwrap_or("").trim().to_string())
        })
        .unwrap_or_else(|| "unknown CPU".into());
    let cores = std::thread::available_parallelism().map(|n| n.get()).unwrap_or(1);
    format!("{cpu}, {cores} cores, {} {}", std::env::consts::OS, std::env::consts::ARCH)
}

fn ratio_cells(r: &Option<Ratio>) -> (String, String) {
    match r {
        Some(r) => (format!("{:.2} [{:.2}..{:.2}]", r.median, r.min, r.max), if r.tie { "tie" } else { "" }.into()),
        None => (String::new(), String::new()),
    }
}

/// docs/BENCHMARKS.md from a report.
pub fn markdown(r: &BenchReport, command: &str) -> String {
    use std::fmt::Write;
    let mut s = String::new();
    let _ = writeln!(s, "<!-- generated by `{command}`; do not edit -->\n\n# Benchmarks\n");
    if !r.complete {
        let _ = writeln!(s, "**Partial run**: the sections below hold what was measured before the run stopped.\n");
    }
    let _ = writeln!(s, "Machine: {}  \nAdapter: {}  \nTiming: {}.\n", r.machine, r.adapter, r.timing);
    let _ = writeln!(
        s,
        "All ratios are measured in this one run: each comparison in {} interleaved rounds, the ratio taken per round; \"median [min..max]\" is over the rounds, and a range that spans 1.0 is a tie.\n",
        r.rounds
    );
    let _ = writeln!(
        s,
        "## Generated vs hand-written\n\nThe generated `<filter>_eval` beside hand-written shaders (runtime/references/, embedded in the binary; each cites its source), on the same random points of a random 64^3-ish volume, after checking max |generated - reference| < {:.0e} of the data range on those points (a comparison that fails the check is marked INVALID and not timed). Ratio: generated ÷ reference evals/s (above 1: the generated code is faster). Ops: `boxforge::emit::count_ops` on the generated eval body; on the reference, the same count over its entry function and, per call site, its own helpers (a vec4 `dot` counts 7), calls to `<filter>_fetch` excluded on both sides; fetches: texel loads over the call tree (naga) plus filtered fetches. Loads only: the generated eval cut after its fetches (same point location, addressing and clamped loads, returning the mean of the samples), timed in the same rounds, ÷ the reference: no evaluation with these loads can be faster, so it bounds the ratio reachable with exact loads on this adapter.\n", REFERENCE_TOLERANCE
    );
    let _ = writeln!(s, "| generated | reference | fetches (gen / ref) | ops (gen / ref) | generated evals/s | reference evals/s | ratio median [min..max] | tie? | loads only ÷ reference | max \\|diff\\| (of range) | source |\n|---|---|---|---|---|---|---|---|---|---|---|");
    for x in &r.references {
        let (ratio, tie) = ratio_cells(&x.ratio);
        let diff = match (x.max_abs_diff, x.rel_diff) {
            (Some(a), Some(rel)) => format!("{a:.2e} ({rel:.1e})"),
            _ => String::new(),
        };
        let status = if let Some(n) = &x.note {
            if x.agrees {
                n.clone()
            } else {
                format!("**{n}**")
            }
        } else {
            String::new()
        };
        let _ = writeln!(
            s,
            "| `{}` | {} (`{}`) | {} / {} | {} / {} | {} | {} | {}{} | {} | {} | {} | {} |",
            x.generated,
            x.reference,
            x.entry,
            x.generated_fetches,
            x.reference_fetches.map(|f| f.to_string()).unwrap_or_else(|| "?".into()),
            x.generated_ops,
            x.reference_ops,
            x.generated_evals_per_s.map(|v| format!("{v:.3e}")).unwrap_or_default(),
            x.reference_evals_per_s.map(|v| format!("{v:.3e}")).unwrap_or_default(),
            ratio,
            if status.is_empty() { String::new() } else { format!(" {status}") },
            tie,
            ratio_cells(&x.loads_only_ratio).0,
            diff,
            x.citation
        );
    }
    if r.references.is_empty() {
        let _ = writeln!(s, "| (no references in this run) | | | | | | | | | | |");
    }
    let _ = writeln!(s, "\n## Evaluation throughput\n\n| filter | layout | variant | kind | evals/s | ratio median [min..max] | tie? | baseline | fetches | ops | sample bytes |\n|---|---|---|---|---|---|---|---|---|---|---|");
    for row in r.rows.iter().filter(|x| x.evals_per_s.is_some()) {
        let (ratio, tie) = ratio_cells(&row.ratio);
        let _ = writeln!(
            s,
            "| {} | {} | {} | {} | {:.3e} | {} | {} | {} | {} | {} | {} |",
            row.filter,
            row.layout,
            row.variant,
            row.kind,
            row.evals_per_s.unwrap_or(0.0),
            ratio,
            tie,
            row.baseline.clone().unwrap_or_default(),
            row.fetches.map(|x| x.to_string()).unwrap_or_default(),
            row.ops.map(|x| x.to_string()).unwrap_or_default(),
            row.bytes.map(|x| x.to_string()).unwrap_or_default(),
        );
    }
    let linear: Vec<String> = r
        .rows
        .iter()
        .filter(|x| x.variant.contains(TAG_LINEAR) && x.kind == "eval")
        .filter_map(|x| {
            let (cell, _) = ratio_cells(&x.ratio);
            let err = x
                .max_rel_diff_to_baseline
                .map(|d| format!(", max |linear - exact| {d:.1e} of the range"))
                .unwrap_or_default();
            (!cell.is_empty())
                .then(|| format!("{} {} {} fetches: {cell}{err}", x.filter, x.layout, x.fetches.unwrap_or(0)))
        })
        .collect();
    if !linear.is_empty() {
        let _ = writeln!(
            s,
            "\n### Linear fetches\n\nlinear ÷ exact fetches, eval, on this adapter: {}. A filtered fetch pays off where a texture unit interpolates at the cost of one load. lavapipe (llvmpipe) filters in software, so there a filtered fetch costs more than a texel load, and the per-sample weights (their pair sums and ratios) cost more arithmetic than the combined forms of exact loads: pairs that each replace two loads (bcc7, bcc8, fcc6 on the packed layout) are expected to lose on lavapipe, while trilinear fetches that each replace eight (the tricubic, embedded) win. Run `boxforge bench` on a GPU before choosing.",
            linear.join("; ")
        );
    }
    let naive: Vec<f64> = r.rows.iter().filter(|x| x.variant == "naive").filter_map(|x| x.ratio_to_baseline).collect();
    let this_run = if naive.is_empty() {
        "no naive variant was timed in this run".to_string()
    } else {
        let (lo, hi) = stats::range(&naive);
        format!("{lo:.0}x to {hi:.0}x in this run")
    };
    let _ = writeln!(
        s,
        "\n### Fast vs naive\n\nThe large fast ÷ naive ratios on lavapipe ({this_run}; 1,000x to 15,000x for fcc6 and bcc7 in full runs) come from lavapipe's handling of dynamic indexing into private arrays: the naive variant keeps its stencil offsets and piece coefficients in lookup tables indexed at run time and loops over them, and llvmpipe lowers such indexing to slow scratch-memory code. They do not come from branches as such, and a GPU with register-indexed constant tables would show a far smaller gap; measure it there before citing a number."
    );
    let _ = writeln!(
        s,
        "\n## Rendering\n\n| filter | image | variant | ms/frame | ratio median [min..max] | tie? | baseline |\n|---|---|---|---|---|---|---|"
    );
    for row in r.rows.iter().filter(|x| x.ms_per_frame.is_some()) {
        let (ratio, tie) = ratio_cells(&row.ratio);
        let _ = writeln!(
            s,
            "| {} | {} | {} | {:.1} | {} | {} | {} |",
            row.filter,
            row.kind,
            row.variant,
            row.ms_per_frame.unwrap_or(0.0),
            ratio,
            tie,
            row.baseline.clone().unwrap_or_default()
        );
    }
    s.push_str(&dvr::markdown(&r.rows));
    let _ = writeln!(s, "\n## Analytic gradient vs central differences (Marschner-Lobb)\n\n| filter | analytic evals/s | central evals/s | speed-up median [min..max] | tie? | analytic angle error (°) | central angle error (°) |\n|---|---|---|---|---|---|---|");
    for g in &r.gradient {
        let (ratio, tie) = ratio_cells(&Some(g.speedup_ratio));
        let _ = writeln!(
            s,
            "| {} | {:.3e} | {:.3e} | {} | {} | {:.3} | {:.3} |",
            g.filter,
            g.analytic_evals_per_s,
            g.central_evals_per_s,
            ratio,
            tie,
            g.analytic_angle_deg,
            g.central_angle_deg
        );
    }
    let _ = writeln!(s, "\n## Quality against the analytic Marschner-Lobb function\n\n| filter | lattice | budget | samples | prefiltered | RMS error | max error | gradient angle error (°) |\n|---|---|---|---|---|---|---|---|");
    for q in &r.quality {
        let _ = writeln!(
            s,
            "| {} | {} | {} | {} | {} | {:.5} | {:.4} | {:.2} |",
            q.filter, q.lattice, q.budget, q.samples, q.prefiltered, q.rms_error, q.max_error, q.gradient_angle_deg
        );
    }
    let _ = writeln!(s, "\n## Convergence on a smooth signal (prefiltered)\n\n| filter | approximation order | edges | RMS errors | measured order |\n|---|---|---|---|---|");
    for c in &r.convergence {
        let _ = writeln!(
            s,
            "| {} | {} | {:?} | {} | {:.2} |",
            c.filter,
            c.approximation_order,
            c.edges,
            c.rms_errors.iter().map(|e| format!("{e:.2e}")).collect::<Vec<_>>().join(", "),
            c.measured_order
        );
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The loads-only cut keeps the eval's point location and every fetch,
    /// drops the arithmetic after them, and is valid WGSL beside the module.
    #[test]
    fn loads_only_keeps_every_fetch_and_nothing_after() {
        for name in ["bcc7", "fcc6", "cc_tricubic"] {
            let d = derive(name).unwrap();
            let m = emit(&d, &EmitOptions { kernels: false, ..Default::default() }).unwrap();
            let cut = loads_only(&m.source, name).unwrap();
            let call = format!("{name}_fetch(");
            assert_eq!(cut.matches(&call).count(), m.stats.fetches_per_eval, "{name}");
            let eval = m.source.split(&format!("fn {name}_eval(")).nth(1).unwrap().split("\n}\n").next().unwrap();
            assert!(boxforge::emit::count_ops(&cut) < boxforge::emit::count_ops(eval), "{name}: nothing was cut");
            let r = boxforge::validate::validate_wgsl(&format!("{}\n{cut}", m.source), name);
            assert!(r.valid, "{name}: {:?}", r.error);
        }
        assert!(loads_only("fn x_eval(p: vec3<f32>) -> f32 {\n    return 1.0;\n}\n", "x").is_none());
    }
}
