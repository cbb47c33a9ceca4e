//! `boxforge bench`: every claim gets a number, measured in one run and
//! reported as ratios against a baseline measured pair by pair.

use crate::gpu::{Gpu, GpuError};
use crate::prefilter::prefilter_cpu;
use crate::render::{self, valid_box, RenderOptions};
use crate::upload::{storage_entry, DeviceVolume};
use crate::verify::{random_volume, Rng};
use crate::volume::{marschner_lobb, marschner_lobb_grad, ml_position, LatticeVolume, Volume};
use boxforge::derive::Derivation;
use boxforge::emit::{emit, EmitOptions, Layout, Variant};
use serde::Serialize;
use std::time::Instant;

#[derive(Clone, Debug, Serialize)]
pub struct BenchRow {
    pub filter: String,
    pub layout: String,
    pub variant: String,
    /// eval, eval_grad, central_differences, external, render_ml_256, ...
    pub kind: String,
    pub evals_per_s: Option<f64>,
    pub ms_per_frame: Option<f64>,
    pub ratio_to_baseline: Option<f64>,
    pub baseline: Option<String>,
    pub fetches: Option<usize>,
    pub ops: Option<usize>,
    pub bytes: Option<usize>,
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
    pub rows: Vec<BenchRow>,
    pub gradient: Vec<GradientRow>,
    pub quality: Vec<QualityRow>,
    pub convergence: Vec<ConvergenceRow>,
}

#[derive(Clone, Debug, Serialize)]
pub struct GradientRow {
    pub filter: String,
    pub analytic_evals_per_s: f64,
    pub central_evals_per_s: f64,
    pub speedup: f64,
    pub analytic_angle_deg: f64,
    pub central_angle_deg: f64,
}

#[derive(Clone, Debug)]
pub struct BenchOptions {
    pub filters: Vec<String>,
    /// Points per throughput dispatch.
    pub points: usize,
    pub runs: usize,
    pub naive: bool,
    /// Filters whose naive variant is measured (its shaders compile slowly
    /// on lavapipe: minutes for the large stencils).
    pub naive_filters: Vec<String>,
    pub render_sizes: Vec<u32>,
    pub mni: Option<String>,
    pub quality: bool,
    pub external: Option<External>,
}

#[derive(Clone, Debug)]
pub struct External {
    pub wgsl: String,
    pub entry: String,
    pub like: String,
}

impl BenchOptions {
    pub fn full() -> BenchOptions {
        BenchOptions {
            filters: ["cc_trilinear", "cc_tricubic", "bcc_linear", "bcc7", "bcc8", "bcc12", "fcc6"]
                .map(String::from)
                .to_vec(),
            points: 1 << 18,
            runs: 5,
            naive: true,
            naive_filters: ["bcc_linear", "bcc7", "fcc6"].map(String::from).to_vec(),
            render_sizes: vec![256, 512],
            mni: Some("data/mni152_t1_1mm.nii.gz".into()),
            quality: true,
            external: None,
        }
    }
    /// Seconds-long version for CI (numbers are not meaningful).
    pub fn smoke() -> BenchOptions {
        BenchOptions {
            filters: vec!["bcc_linear".into()],
            points: 4096,
            runs: 1,
            naive: true,
            naive_filters: vec!["bcc_linear".into()],
            render_sizes: vec![32],
            mni: None,
            quality: true,
            external: None,
        }
    }
}

/// A throughput kernel: evaluates `call` (an expression of p) at every point.
fn kernel(call: &str) -> String {
    format!(
        "
@group(1) @binding(0) var<storage, read> bx_points: array<vec4<f32>>;
@group(1) @binding(1) var<storage, read_write> bx_out: array<vec4<f32>>;

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

/// Central differences from 6 extra evaluations (h = 1e-2 cell).
fn central_call(name: &str) -> String {
    format!(
        "vec4<f32>({n}_eval(p), ({n}_eval(p + vec3<f32>(0.01, 0.0, 0.0)) - {n}_eval(p - vec3<f32>(0.01, 0.0, 0.0))) * 50.0, ({n}_eval(p + vec3<f32>(0.0, 0.01, 0.0)) - {n}_eval(p - vec3<f32>(0.0, 0.01, 0.0))) * 50.0, ({n}_eval(p + vec3<f32>(0.0, 0.0, 0.01)) - {n}_eval(p - vec3<f32>(0.0, 0.0, 0.01))) * 50.0)",
        n = name
    )
}

/// Runs `source`'s bench_main over the points: (evals/s from the median of
/// `runs` timed dispatches after a warm-up, outputs).
fn throughput(
    gpu: &Gpu,
    source: &str,
    label: &str,
    dv: &DeviceVolume,
    points: &[[f32; 4]],
    runs: usize,
) -> Result<(f64, Vec<[f32; 4]>), GpuError> {
    let shader = gpu.compile(label, source)?;
    let dev = &gpu.device;
    let bgl0 = dev.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
        label: None,
        entries: &dv.layout_entries(0, wgpu::ShaderStages::COMPUTE),
    });
    let bgl1 = dev.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
        label: None,
        entries: &[storage_entry(0, true), storage_entry(1, false)],
    });
    let pipeline = gpu.pipeline(label, &shader, &[&bgl0, &bgl1], "bench_main")?;
    let n = points.len();
    let pts = gpu.storage_buffer("points", bytemuck::cast_slice(points), false);
    let out = gpu.storage_buffer("out", &vec![0u8; n * 16], true);
    let bg0 =
        dev.create_bind_group(&wgpu::BindGroupDescriptor { label: None, layout: &bgl0, entries: &dv.bind_entries(0) });
    let bg1 = dev.create_bind_group(&wgpu::BindGroupDescriptor {
        label: None,
        layout: &bgl1,
        entries: &[
            wgpu::BindGroupEntry { binding: 0, resource: pts.as_entire_binding() },
            wgpu::BindGroupEntry { binding: 1, resource: out.as_entire_binding() },
        ],
    });
    let groups = n.div_ceil(64) as u32;
    let (gx, gy) = (groups.min(65535), groups.div_ceil(65535));
    // GPU time from timestamp queries when the adapter has them, else wall
    // time around submit + wait.
    let queries = gpu.timestamps.then(|| {
        let set =
            dev.create_query_set(&wgpu::QuerySetDescriptor { label: None, ty: wgpu::QueryType::Timestamp, count: 2 });
        let resolve = dev.create_buffer(&wgpu::BufferDescriptor {
            label: Some("timestamps"),
            size: 16,
            usage: wgpu::BufferUsages::QUERY_RESOLVE | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        });
        (set, resolve)
    });
    let run = || -> Result<f64, GpuError> {
        let start = Instant::now();
        let mut enc = dev.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: None });
        {
            let timestamp_writes = queries.as_ref().map(|(set, _)| wgpu::ComputePassTimestampWrites {
                query_set: set,
                beginning_of_pass_write_index: Some(0),
                end_of_pass_write_index: Some(1),
            });
            let mut pass = enc.begin_compute_pass(&wgpu::ComputePassDescriptor { label: None, timestamp_writes });
            pass.set_pipeline(&pipeline);
            pass.set_bind_group(0, &bg0, &[]);
            pass.set_bind_group(1, &bg1, &[]);
            pass.dispatch_workgroups(gx, gy, 1);
        }
        if let Some((set, resolve)) = &queries {
            enc.resolve_query_set(set, 0..2, resolve, 0);
        }
        gpu.queue.submit([enc.finish()]);
        gpu.wait()?;
        let wall = start.elapsed().as_secs_f64();
        if let Some((_, resolve)) = &queries {
            let ts: Vec<u64> = bytemuck::cast_slice(&gpu.read_buffer(resolve)?).to_vec();
            let gpu_s = ts[1].saturating_sub(ts[0]) as f64 * gpu.queue.get_timestamp_period() as f64 * 1e-9;
            if gpu_s > 0.0 {
                return Ok(gpu_s);
            }
        }
        Ok(wall)
    };
    run()?; // warm-up (includes pipeline compilation on lavapipe)
    let mut t: Vec<f64> = (0..runs.max(1)).map(|_| run()).collect::<Result<_, _>>()?;
    t.sort_by(|a, b| a.total_cmp(b));
    let median = t[t.len() / 2];
    let outv: Vec<[f32; 4]> = bytemuck::cast_slice(&gpu.read_buffer(&out)?).to_vec();
    Ok((n as f64 / median, outv))
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

pub fn run(gpu: &Gpu, o: &BenchOptions, progress: &dyn Fn(&str)) -> Result<BenchReport, String> {
    let mut rows = Vec::new();
    let mut gradient = Vec::new();
    let e = |x: GpuError| x.to_string();
    for name in &o.filters {
        let d = derive(name)?;
        if d.facts.dim != 3 {
            continue;
        }
        let vol = random_volume(&d, 11);
        let pts = crate::verify::random_points(&d, &vol, o.points, 11);
        let mut fast_embedded: Option<(f64, f64)> = None;
        for layout in [Layout::Embedded, Layout::Packed] {
            let dv = DeviceVolume::new(gpu, &vol, layout).map_err(e)?;
            // The naive variant runs ~1000x slower on lavapipe and its shaders
            // take minutes to compile there: time it on the embedded layout
            // with fewer points (evals/s is a rate, so the ratio stands).
            let with_naive = o.naive && o.naive_filters.contains(name) && layout == Layout::Embedded;
            let variants: &[Variant] = if with_naive { &[Variant::Fast, Variant::Naive] } else { &[Variant::Fast] };
            let mut fast: Option<(f64, f64)> = None;
            for &variant in variants {
                let m = emit(&d, &EmitOptions { layout, variant, kernels: false, ..Default::default() })
                    .map_err(|x| x.to_string())?;
                for (kind, call) in [
                    ("eval", format!("vec4<f32>({name}_eval(p), 0.0, 0.0, 0.0)")),
                    ("eval_grad", format!("{name}_eval_grad(p)")),
                ] {
                    progress(&format!("{name} {} {} {kind}", layout.name(), variant.name()));
                    let src = format!("{}\n{}", m.source, kernel(&call));
                    let sample = if variant == Variant::Naive { &pts[..pts.len().min(8192)] } else { &pts[..] };
                    let (eps, _) = throughput(gpu, &src, &m.file_name, &dv, sample, o.runs).map_err(e)?;
                    let (ratio, baseline) = match (variant, layout, kind) {
                        (Variant::Naive, _, "eval") => (fast.map(|f| f.0 / eps), Some("fast ÷ naive".to_string())),
                        (Variant::Naive, _, _) => (fast.map(|f| f.1 / eps), Some("fast ÷ naive".to_string())),
                        (Variant::Fast, Layout::Packed, "eval") => {
                            (fast_embedded.map(|f| eps / f.0), Some("packed ÷ embedded".to_string()))
                        }
                        (Variant::Fast, Layout::Packed, _) => {
                            (fast_embedded.map(|f| eps / f.1), Some("packed ÷ embedded".to_string()))
                        }
                        _ => (None, None),
                    };
                    if variant == Variant::Fast {
                        let f = fast.get_or_insert((0.0, 0.0));
                        if kind == "eval" {
                            f.0 = eps;
                        } else {
                            f.1 = eps;
                        }
                    }
                    rows.push(BenchRow {
                        filter: name.clone(),
                        layout: layout.name().into(),
                        variant: variant.name().into(),
                        kind: kind.into(),
                        evals_per_s: Some(eps),
                        ms_per_frame: None,
                        ratio_to_baseline: ratio,
                        baseline,
                        fetches: Some(m.stats.fetches_per_eval),
                        ops: Some(if kind == "eval" { m.stats.ops_eval } else { m.stats.ops_eval_grad }),
                        bytes: Some(dv.bytes),
                    });
                }
            }
            if layout == Layout::Embedded {
                fast_embedded = fast;
            }
        }
        // Analytic gradient vs central differences, on Marschner-Lobb.
        let e3 = crate::scene::matched_edge(&d.filter.lattice, 41f64.powi(3));
        let ml = LatticeVolume::marschner_lobb(&d.filter.lattice, [e3, e3, e3]).map_err(|x| x.to_string())?;
        let dv = DeviceVolume::new(gpu, &ml, Layout::Embedded).map_err(e)?;
        let mpts = points_in(&d, &ml, o.points, 5);
        let m = emit(&d, &EmitOptions { kernels: false, ..Default::default() }).map_err(|x| x.to_string())?;
        progress(&format!("{name} analytic vs central-difference gradient"));
        let (a_eps, a_out) = throughput(
            gpu,
            &format!("{}\n{}", m.source, kernel(&format!("{name}_eval_grad(p)"))),
            "grad",
            &dv,
            &mpts,
            o.runs,
        )
        .map_err(e)?;
        let (c_eps, c_out) =
            throughput(gpu, &format!("{}\n{}", m.source, kernel(&central_call(name))), "central", &dv, &mpts, o.runs)
                .map_err(e)?;
        rows.push(BenchRow {
            filter: name.clone(),
            layout: "embedded".into(),
            variant: "fast".into(),
            kind: "central_differences".into(),
            evals_per_s: Some(c_eps),
            ms_per_frame: None,
            ratio_to_baseline: Some(a_eps / c_eps),
            baseline: Some("analytic eval_grad ÷ central differences".into()),
            fetches: Some(m.stats.fetches_per_eval * 7),
            ops: None,
            bytes: None,
        });
        gradient.push(GradientRow {
            filter: name.clone(),
            analytic_evals_per_s: a_eps,
            central_evals_per_s: c_eps,
            speedup: a_eps / c_eps,
            analytic_angle_deg: ml_angle(&ml, &mpts, &a_out),
            central_angle_deg: ml_angle(&ml, &mpts, &c_out),
        });
        // Rendering.
        for &size in &o.render_sizes {
            let mut with_skip = None;
            for skip in [true, false] {
                progress(&format!("{name} render Marschner-Lobb {size}^2 skip={skip}"));
                let ro = RenderOptions {
                    width: size,
                    height: size,
                    skip,
                    frames: o.runs.max(1),
                    ..RenderOptions::default()
                };
                let f = render::render(gpu, &d, &ml, Layout::Embedded, &ro).map_err(e)?;
                rows.push(render_row(name, &format!("render_ml_{size}"), skip, f.ms_per_frame, with_skip));
                if skip {
                    with_skip = Some(f.ms_per_frame);
                }
            }
        }
    }
    // bcc7 against bcc8, and the external shader.
    add_pair_ratio(&mut rows, "bcc7", "bcc8");
    if let Some(ext) = &o.external {
        rows.extend(external(gpu, ext, o)?);
    }
    // The MNI head.
    if let Some(path) = &o.mni {
        let head = Volume::load_nifti(std::path::Path::new(path)).map_err(|x| x.to_string())?;
        for name in o.filters.iter().filter(|n| ["bcc7", "bcc8", "fcc6", "cc_tricubic"].contains(&n.as_str())) {
            let d = derive(name)?;
            let v = crate::scene::from_cartesian(&head, &d.filter.lattice, crate::scene::Conversion::Resample)
                .map_err(|x| x.to_string())?;
            for &size in &o.render_sizes {
                let mut with_skip = None;
                for skip in [true, false] {
                    progress(&format!("{name} render MNI {size}^2 skip={skip}"));
                    let ro = RenderOptions {
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
                    let f = render::render(gpu, &d, &v, Layout::Embedded, &ro).map_err(e)?;
                    rows.push(render_row(name, &format!("render_mni_{size}"), skip, f.ms_per_frame, with_skip));
                    if skip {
                        with_skip = Some(f.ms_per_frame);
                    }
                }
            }
        }
    }
    let (quality, convergence) = if o.quality { quality(gpu, o, progress)? } else { (vec![], vec![]) };
    Ok(BenchReport {
        machine: machine_info(),
        adapter: gpu.describe(),
        timing: if gpu.timestamps {
            "GPU time of one dispatch from timestamp queries (throughput rows), wall time around submit + wait (render rows); median of the timed runs after a warm-up".into()
        } else {
            "wall time around submit + wait of one dispatch, median of the timed runs after a warm-up".into()
        },
        rows,
        gradient,
        quality,
        convergence,
    })
}

fn render_row(name: &str, kind: &str, skip: bool, ms: f64, with_skip: Option<f64>) -> BenchRow {
    BenchRow {
        filter: name.into(),
        layout: "embedded".into(),
        variant: if skip { "fast, skipping" } else { "fast, no skipping" }.into(),
        kind: kind.into(),
        evals_per_s: None,
        ms_per_frame: Some(ms),
        ratio_to_baseline: if skip { None } else { with_skip.map(|w| ms / w) },
        baseline: if skip { None } else { Some("no skipping ÷ skipping (time)".into()) },
        fetches: None,
        ops: None,
        bytes: None,
    }
}

fn add_pair_ratio(rows: &mut Vec<BenchRow>, a: &str, b: &str) {
    for kind in ["eval", "eval_grad"] {
        let find = |n: &str| {
            rows.iter()
                .find(|r| r.filter == n && r.kind == kind && r.layout == "embedded" && r.variant == "fast")
                .and_then(|r| r.evals_per_s)
        };
        if let (Some(x), Some(y)) = (find(a), find(b)) {
            rows.push(BenchRow {
                filter: a.into(),
                layout: "embedded".into(),
                variant: "fast".into(),
                kind: format!("{kind}_vs_{b}"),
                evals_per_s: Some(x),
                ms_per_frame: None,
                ratio_to_baseline: Some(x / y),
                baseline: Some(format!("{a} ÷ {b}")),
                fetches: None,
                ops: None,
                bytes: None,
            });
        }
    }
}

/// A user-supplied WGSL function timed beside the generated one.
fn external(gpu: &Gpu, ext: &External, o: &BenchOptions) -> Result<Vec<BenchRow>, String> {
    let d = derive(&ext.like)?;
    let user = std::fs::read_to_string(&ext.wgsl).map_err(|x| format!("cannot read {}: {x}", ext.wgsl))?;
    let vol = random_volume(&d, 11);
    let pts = crate::verify::random_points(&d, &vol, o.points, 11);
    let dv = DeviceVolume::new(gpu, &vol, Layout::Embedded).map_err(|x| x.to_string())?;
    let m = emit(&d, &EmitOptions { kernels: false, ..Default::default() }).map_err(|x| x.to_string())?;
    let name = &d.filter.name;
    let ours = format!("{}\n{}", m.source, kernel(&format!("vec4<f32>({name}_eval(p), 0.0, 0.0, 0.0)")));
    let theirs = format!("{}\n{}\n{}", m.source, user, kernel(&format!("vec4<f32>({}(p), 0.0, 0.0, 0.0)", ext.entry)));
    let (a, va) = throughput(gpu, &ours, "generated", &dv, &pts, o.runs).map_err(|x| x.to_string())?;
    let (b, vb) = throughput(gpu, &theirs, &ext.wgsl, &dv, &pts, o.runs).map_err(|x| x.to_string())?;
    let max_diff = va.iter().zip(&vb).map(|(x, y)| (x[0] - y[0]).abs()).fold(0f32, f32::max);
    Ok(vec![BenchRow {
        filter: ext.like.clone(),
        layout: "embedded".into(),
        variant: format!("external {}::{} (max |diff| to generated {:.2e})", ext.wgsl, ext.entry, max_diff),
        kind: "eval".into(),
        evals_per_s: Some(b),
        ms_per_frame: None,
        ratio_to_baseline: Some(a / b),
        baseline: Some("generated ÷ external".into()),
        fetches: None,
        ops: None,
        bytes: None,
    }])
}

/// Errors against Marschner-Lobb at matched budgets, with and without the
/// prefilter, and convergence orders on a smooth signal.
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
        // Convergence on a smooth signal (prefiltered): f = cos(1.5x) cos(y) cos(0.5z) on [-1,1]^3.
        progress(&format!("{name} convergence"));
        let smooth = |x: [f64; 3]| (1.5 * x[0]).cos() * x[1].cos() * (0.5 * x[2]).cos();
        let edges: Vec<usize> = vec![16, 24, 32];
        let mut errs = Vec::new();
        let mut hs = Vec::new();
        for &n in &edges {
            let r = crate::verify::support_radius(&d);
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
                            v.data[x + dims[0] * (y + dims[1] * z)] =
                                smooth(to_x([x as f64, y as f64, z as f64])) as f32;
                        }
                    }
                }
            }
            let v = prefilter_cpu(&d, &v);
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
            let (vals, _) = crate::verify::gpu_eval(gpu, &d, &dv, Variant::Fast, &pts).map_err(|x| x.to_string())?;
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
            hs.push(1.0 / n as f64);
        }
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

/// docs/BENCHMARKS.md from a report.
pub fn markdown(r: &BenchReport, command: &str) -> String {
    use std::fmt::Write;
    let mut s = String::new();
    let _ = writeln!(s, "<!-- generated by `{command}`; do not edit -->\n\n# Benchmarks\n");
    let _ = writeln!(s, "Machine: {}  \nAdapter: {}  \nTiming: {}.\n", r.machine, r.adapter, r.timing);
    let _ = writeln!(s, "All ratios are measured in this one run, pair by pair.\n");
    let _ = writeln!(s, "## Evaluation throughput\n\n| filter | layout | variant | kind | evals/s | ratio | baseline | fetches | ops | sample bytes |\n|---|---|---|---|---|---|---|---|---|---|");
    for row in r.rows.iter().filter(|x| x.evals_per_s.is_some()) {
        let _ = writeln!(
            s,
            "| {} | {} | {} | {} | {:.3e} | {} | {} | {} | {} | {} |",
            row.filter,
            row.layout,
            row.variant,
            row.kind,
            row.evals_per_s.unwrap_or(0.0),
            row.ratio_to_baseline.map(|x| format!("{x:.2}")).unwrap_or_default(),
            row.baseline.clone().unwrap_or_default(),
            row.fetches.map(|x| x.to_string()).unwrap_or_default(),
            row.ops.map(|x| x.to_string()).unwrap_or_default(),
            row.bytes.map(|x| x.to_string()).unwrap_or_default(),
        );
    }
    let _ = writeln!(
        s,
        "\n## Rendering\n\n| filter | image | variant | ms/frame | ratio | baseline |\n|---|---|---|---|---|---|"
    );
    for row in r.rows.iter().filter(|x| x.ms_per_frame.is_some()) {
        let _ = writeln!(
            s,
            "| {} | {} | {} | {:.1} | {} | {} |",
            row.filter,
            row.kind,
            row.variant,
            row.ms_per_frame.unwrap_or(0.0),
            row.ratio_to_baseline.map(|x| format!("{x:.2}")).unwrap_or_default(),
            row.baseline.clone().unwrap_or_default()
        );
    }
    let _ = writeln!(s, "\n## Analytic gradient vs central differences (Marschner-Lobb)\n\n| filter | analytic evals/s | central evals/s | speed-up | analytic angle error (°) | central angle error (°) |\n|---|---|---|---|---|---|");
    for g in &r.gradient {
        let _ = writeln!(
            s,
            "| {} | {:.3e} | {:.3e} | {:.2} | {:.3} | {:.3} |",
            g.filter,
            g.analytic_evals_per_s,
            g.central_evals_per_s,
            g.speedup,
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
