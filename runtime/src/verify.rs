//! `boxforge verify`: the emitted `eval` / `eval_grad` on the device against
//! the exact evaluator (f64) at random points of a random volume.

use crate::gpu::binding::storage_entry;
use crate::gpu::{Gpu, GpuError};
/// Re-exported where the device checks have always offered them.
pub use crate::par::par_map;
pub use crate::volume::support_radius;
use crate::volume::LatticeVolume;
use crate::volume::{BrickShape, DeviceVolume, VolumeOptions};
use boxforge::derive::Derivation;
use boxforge::emit::{emit, Bounds, EmitOptions, EvalForm, FetchMode, Layout, Variant};
pub use exact::{cpu_eval, knot_tolerance, near_knot, nearest_knot_planes, Tally, GRADIENT_TOLERANCE, VALUE_TOLERANCE};
pub use inputs::{brick_face_points, data_range, random_points, random_volume, Rng};

pub mod exact;
pub mod four;
pub mod hessian;
pub mod inputs;
pub mod kernel;
#[cfg(feature = "targets")]
pub mod target;

/// Why a verification (or an evaluation on the device) could not run.
#[derive(Debug, thiserror::Error)]
pub enum VerifyError {
    #[error(transparent)]
    Gpu(#[from] GpuError),
    /// A volume the device cannot hold in the requested layout.
    #[error(transparent)]
    Volume(#[from] crate::volume::VolumeError),
    /// The generator refused the module (its message names the reason).
    #[error(transparent)]
    Emit(#[from] boxforge::Error),
    /// Linear fetches asked of a 4D filter, whose samples no sampler filters.
    #[error("4D samples are a storage buffer, which no sampler filters: verify 4D filters with exact fetches")]
    FourDLinear,
    /// A Vulkan run of a translation asked for without a device.
    #[error("a Vulkan run of a translation needs a device: open one (Gpu::new) or run it on GL")]
    NoDevice,
    #[error("{filter} is {dim}D: the runtime verifies 3D filters here, and 4D ones as WGSL (no translation); 2D shaders are checked by naga only")]
    NotThreeD { filter: String, dim: usize },
    #[error("the points count must be at least 1")]
    NoPoints,
    /// A translation that could not be run (`verify --target`).
    #[cfg(feature = "targets")]
    #[error(transparent)]
    Target(#[from] crate::targets::TargetError),
}

#[derive(Clone, Debug)]
#[cfg_attr(feature = "files", derive(serde::Serialize))]
pub struct VerifyReport {
    pub filter: String,
    pub layout: Layout,
    pub variant: Variant,
    /// The evaluation form that was emitted (the filter's choice unless forced).
    pub form: EvalForm,
    pub bounds: Bounds,
    pub fetch: FetchMode,
    pub points: usize,
    /// max |GPU value - exact value| (also over eval vs eval_grad.x).
    pub max_abs_err: f64,
    /// max over points of |grad_gpu - grad_exact|_inf / max(|grad_exact|_inf, data range).
    pub max_rel_grad_err: f64,
    pub data_range: f64,
    /// Points within f32 rounding of a knot plane ([`knot_tolerance`]): the
    /// device may place them in the piece on either side.
    pub near_knot_points: usize,
    /// Near-knot points whose device value and gradient match a neighbouring
    /// piece (not the one the exact evaluator picked) and were accepted so.
    pub accepted_other_side: usize,
    /// The form of `eval_hessian` (None: the module has none, degree < 2).
    pub hessian_form: Option<EvalForm>,
    /// max over points of |H_gpu - H_exact|_max / max(|H_exact|_max, data
    /// range), `eval_hessian`'s value and gradient held to the tolerances above.
    pub max_rel_hessian_err: Option<f64>,
    /// Near-knot points whose device Hessian matched a neighbouring piece.
    pub hessian_accepted_other_side: usize,
    pub passed: bool,
    pub adapter: String,
}

/// The compute wrapper that evaluates `<name>_eval_grad` and `<name>_eval`
/// at a list of points (entry `verify_main`, group 1: points, gradients, values).
fn wrapper(name: &str) -> String {
    let (grad, value) = (format!("{name}_eval_grad(p)"), format!("{name}_eval(p)"));
    kernel::points_kernel(
        "verify_main",
        1,
        "vf",
        &[
            kernel::Output { name: "grad", ty: "vec4<f32>", expr: &grad },
            kernel::Output { name: "value", ty: "f32", expr: &value },
        ],
    )
}

/// Evaluates eval and eval_grad on the device at `points`: (values, value+gradient).
pub fn gpu_eval(
    gpu: &Gpu,
    d: &Derivation,
    vol: &DeviceVolume,
    variant: Variant,
    points: &[[f32; 4]],
) -> Result<(Vec<f32>, Vec<[f32; 4]>), VerifyError> {
    gpu_eval_with(gpu, d, vol, variant, None, Bounds::Clamp, points).map(|(v, g, _)| (v, g))
}

/// Values, gradients (xyz, w unused) and the evaluation form that was emitted.
pub type GpuValues = (Vec<f32>, Vec<[f32; 4]>, EvalForm);

/// The module `verify` runs on `vol`: its layout, and linear fetches when
/// the volume is bound for hardware filtering.
fn verify_module(
    d: &Derivation,
    vol: &DeviceVolume,
    variant: Variant,
    form: Option<EvalForm>,
    bounds: Bounds,
) -> Result<boxforge::emit::Emitted, VerifyError> {
    Ok(emit(
        d,
        &EmitOptions {
            layout: vol.layout,
            variant,
            kernels: false,
            command: "boxforge verify".into(),
            form,
            bounds,
            fetch: if vol.filtered() { FetchMode::Linear } else { FetchMode::Exact },
            samples: vol.map,
            texels: vol.format.texels(),
            ..Default::default()
        },
    )?)
}

/// [`gpu_eval`] with a forced evaluation form and a bounds policy; also
/// returns the form that was emitted.
pub fn gpu_eval_with(
    gpu: &Gpu,
    d: &Derivation,
    vol: &DeviceVolume,
    variant: Variant,
    form: Option<EvalForm>,
    bounds: Bounds,
    points: &[[f32; 4]],
) -> Result<GpuValues, VerifyError> {
    let module = verify_module(d, vol, variant, form, bounds)?;
    let used = module.stats.form;
    let (v, g) = gpu_eval_source(gpu, &module.source, &module.file_name, &d.filter.name, vol, points)?;
    Ok((v, g, used))
}

/// Points per dispatch: large point counts are split into dispatches of this
/// many (16 MiB of gradients each), well inside every adapter's storage
/// binding and workgroup-count limits.
pub const POINTS_PER_DISPATCH: usize = 1 << 20;

/// Runs any module that defines `<name>_eval` and `<name>_eval_grad` with the
/// sample bindings of `vol`'s layout at group 0 (e.g. one generated by
/// `boxforge::Builder` and included with `include_str!`).
pub fn gpu_eval_source(
    gpu: &Gpu,
    module_source: &str,
    label: &str,
    name: &str,
    vol: &DeviceVolume,
    points: &[[f32; 4]],
) -> Result<(Vec<f32>, Vec<[f32; 4]>), GpuError> {
    PointEvaluator::new(gpu, module_source, label, name, vol)?.eval(points)
}

/// Compiles `source` (a module with a [`kernel::points_kernel`] at group 1
/// with `outputs` outputs, entry `entry`) over `vol`'s samples at group 0:
/// the pipeline, the layout of group 1 (points, then the outputs) and the
/// samples' bind group.
pub(crate) fn points_pipeline(
    gpu: &Gpu,
    source: &str,
    label: &str,
    vol: &DeviceVolume,
    outputs: u32,
    entry: &str,
) -> Result<(wgpu::ComputePipeline, wgpu::BindGroupLayout, wgpu::BindGroup), GpuError> {
    let shader = gpu.compile(label, source)?;
    let dev = &gpu.device;
    let bgl0 = dev.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
        label: Some("samples"),
        entries: &vol.layout_entries(0, wgpu::ShaderStages::COMPUTE),
    });
    let io: Vec<wgpu::BindGroupLayoutEntry> =
        std::iter::once(storage_entry(0, true)).chain((1..=outputs).map(|b| storage_entry(b, false))).collect();
    let bgl1 = dev.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor { label: Some("io"), entries: &io });
    let pipeline = gpu.pipeline(entry, &shader, &[&bgl0, &bgl1], entry)?;
    let bg0 = gpu.checked("bind the samples", || {
        dev.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("samples"),
            layout: &bgl0,
            entries: &vol.bind_entries(0),
        })
    })?;
    Ok((pipeline, bgl1, bg0))
}

/// A compiled evaluation wrapper around a module, run on any number of
/// points (split into dispatches of [`POINTS_PER_DISPATCH`]).
pub struct PointEvaluator<'a> {
    gpu: &'a Gpu,
    pipeline: wgpu::ComputePipeline,
    bgl1: wgpu::BindGroupLayout,
    bg0: wgpu::BindGroup,
}

impl<'a> PointEvaluator<'a> {
    pub fn new(
        gpu: &'a Gpu,
        module_source: &str,
        label: &str,
        name: &str,
        vol: &DeviceVolume,
    ) -> Result<PointEvaluator<'a>, GpuError> {
        let source = format!("{module_source}\n{}", wrapper(name));
        let (pipeline, bgl1, bg0) = points_pipeline(gpu, &source, label, vol, 2, "verify_main")?;
        Ok(PointEvaluator { gpu, pipeline, bgl1, bg0 })
    }

    /// (values, value + gradient) at every point; an empty list gives empty results.
    pub fn eval(&self, points: &[[f32; 4]]) -> Result<(Vec<f32>, Vec<[f32; 4]>), GpuError> {
        let mut values = Vec::with_capacity(points.len());
        let mut grads = Vec::with_capacity(points.len());
        for chunk in points.chunks(POINTS_PER_DISPATCH) {
            let (v, g) = self.eval_chunk(chunk)?;
            values.extend(v);
            grads.extend(g);
        }
        Ok((values, grads))
    }

    fn eval_chunk(&self, points: &[[f32; 4]]) -> Result<(Vec<f32>, Vec<[f32; 4]>), GpuError> {
        let (gpu, dev) = (self.gpu, &self.gpu.device);
        let n = points.len();
        let pts = gpu.storage_buffer("points", bytemuck::cast_slice(points), false);
        let grad = gpu.storage_buffer("grad", &vec![0u8; n * 16], true);
        let value = gpu.storage_buffer("value", &vec![0u8; n * 4], true);
        let bg1 = gpu.checked("bind the points", || {
            dev.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("io"),
                layout: &self.bgl1,
                entries: &[
                    wgpu::BindGroupEntry { binding: 0, resource: pts.as_entire_binding() },
                    wgpu::BindGroupEntry { binding: 1, resource: grad.as_entire_binding() },
                    wgpu::BindGroupEntry { binding: 2, resource: value.as_entire_binding() },
                ],
            })
        })?;
        let (gx, gy) = kernel::dispatch_size(n);
        gpu.dispatch("verify", &self.pipeline, &[&self.bg0, &bg1], (gx, gy, 1))?;
        let g: Vec<[f32; 4]> = bytemuck::cast_slice(&gpu.read_buffer(&grad)?).to_vec();
        let v: Vec<f32> = bytemuck::cast_slice(&gpu.read_buffer(&value)?).to_vec();
        Ok((v, g))
    }
}

pub fn verify(
    gpu: &Gpu,
    d: &Derivation,
    layout: Layout,
    variant: Variant,
    points: usize,
    seed: u64,
) -> Result<VerifyReport, VerifyError> {
    verify_with(gpu, d, layout, variant, None, Bounds::Clamp, points, seed)
}

/// [`verify`] with a forced evaluation form (None: the filter's own) and a
/// bounds policy (the random points keep the whole support inside the
/// volume, so `unchecked` must agree too).
#[allow(clippy::too_many_arguments)]
pub fn verify_with(
    gpu: &Gpu,
    d: &Derivation,
    layout: Layout,
    variant: Variant,
    form: Option<EvalForm>,
    bounds: Bounds,
    points: usize,
    seed: u64,
) -> Result<VerifyReport, VerifyError> {
    verify_fetch(gpu, d, layout, variant, form, bounds, FetchMode::Exact, points, seed)
}

/// The refusals every verify shares: a 3D filter, at least one point.
pub(crate) fn check_request(d: &Derivation, points: usize) -> Result<(), VerifyError> {
    if d.facts.dim != 3 {
        return Err(VerifyError::NotThreeD { filter: d.filter.name.clone(), dim: d.facts.dim });
    }
    if points == 0 {
        return Err(VerifyError::NoPoints);
    }
    Ok(())
}

/// The brick edge `verify` cuts its volumes into: small, so that most
/// points' stencils cross a brick face and the slots wrap in the pool.
pub const VERIFY_BRICK_EDGE: usize = 4;

/// `vol` on the device for `fetch`: bound for hardware filtering when
/// linear; bricked in bricks of [`VERIFY_BRICK_EDGE`] with exactly the halo
/// `d`'s stencils need (so a halo derived too narrow fails), in a pool only
/// five slots wide (the slots wrap onto rows and layers).
pub(crate) fn device_volume(
    gpu: &Gpu,
    d: &Derivation,
    vol: &LatticeVolume,
    layout: Layout,
    fetch: FetchMode,
) -> Result<DeviceVolume, VerifyError> {
    Ok(match (fetch, layout) {
        (FetchMode::Exact, Layout::Bricked | Layout::BrickedPacked) => {
            let h = boxforge::emit::bricks::brick_halo(d);
            // Coset-packed slots need an even halo.
            let halo = if layout == Layout::BrickedPacked { h.next_multiple_of(2) } else { h };
            let bricks = BrickShape { edge: VERIFY_BRICK_EDGE, halo };
            let options = VolumeOptions { bricks, max_pool_edge: Some(5 * bricks.slot()), ..Default::default() };
            DeviceVolume::with_options(gpu, vol, layout, &options)?
        }
        (FetchMode::Linear, _) => DeviceVolume::new_filtered(gpu, vol, layout)?,
        (FetchMode::Exact, _) => DeviceVolume::new(gpu, vol, layout)?,
    })
}

/// `eval` at `points` seeded random points of `vol`, chunk by chunk (so a
/// hundred million points need no more memory than one chunk), each chunk
/// checked against the exact evaluator.
pub(crate) fn tally_points<E>(
    d: &Derivation,
    vol: &LatticeVolume,
    points: usize,
    seed: u64,
    mut eval: impl FnMut(&[[f32; 4]]) -> Result<(Vec<f32>, Vec<[f32; 4]>), E>,
) -> Result<Tally, E> {
    let mut tally = Tally::new(data_range(vol));
    let mut done = 0;
    let mut chunk_index = 0u64;
    while done < points {
        let count = (points - done).min(POINTS_PER_DISPATCH);
        let chunk_seed = if chunk_index == 0 { seed } else { seed ^ chunk_index.wrapping_mul(0x9E37_79B9_7F4A_7C15) };
        let pts = random_points(d, vol, count, chunk_seed);
        let (values, grads) = eval(&pts)?;
        tally.check(d, vol, &pts, &values, &grads);
        done += count;
        chunk_index += 1;
    }
    Ok(tally)
}

/// [`verify_with`] with a fetch mode: `FetchMode::Linear` binds the samples
/// for hardware filtering ([`DeviceVolume::new_filtered`]); lavapipe filters
/// in float, so the same tolerance applies.
#[allow(clippy::too_many_arguments)]
pub fn verify_fetch(
    gpu: &Gpu,
    d: &Derivation,
    layout: Layout,
    variant: Variant,
    form: Option<EvalForm>,
    bounds: Bounds,
    fetch: FetchMode,
    points: usize,
    seed: u64,
) -> Result<VerifyReport, VerifyError> {
    if d.facts.dim == 4 {
        if fetch == FetchMode::Linear {
            return Err(VerifyError::FourDLinear);
        }
        return four::verify4(gpu, d, layout, variant, form, bounds, points, seed);
    }
    check_request(d, points)?;
    let vol = random_volume(d, seed);
    let dv = device_volume(gpu, d, &vol, layout, fetch)?;
    let module = verify_module(d, &dv, variant, form, bounds)?;
    let used = module.stats.form;
    let evaluator = PointEvaluator::new(gpu, &module.source, &module.file_name, &d.filter.name, &dv)?;
    let range = data_range(&vol);
    let mut tally = tally_points(d, &vol, points, seed, |pts| evaluator.eval(pts))?;
    if let Some(b) = dv.bricks {
        // Bricked: as many points again on the brick faces, where the brick
        // choice (floor(p / B) in f32) and the halo meet.
        let base = random_points(d, &vol, points.min(POINTS_PER_DISPATCH), seed ^ 0xB41C);
        let faces = brick_face_points(d, &vol, &base, b.edge);
        let (values, grads) = evaluator.eval(&faces)?;
        tally.check(d, &vol, &faces, &values, &grads);
    }
    // Second order, at the same points (and brick faces). `eval_hessian`
    // always reads exact loads (only `eval` takes hardware-filtered
    // fetches), so a linear-fetch module's Hessian is the exact-fetch one:
    // it is checked with exact fetches only.
    let mut hessian_tally = None;
    if module.stats.hessian_form.is_some() && fetch == FetchMode::Exact {
        let hev = hessian::HessianEvaluator::new(gpu, &module.source, &module.file_name, &d.filter.name, &dv)?;
        let mut t = hessian::HessianTally::new(range);
        let mut pts = random_points(d, &vol, points.min(POINTS_PER_DISPATCH), seed);
        if let Some(b) = dv.bricks {
            let base = random_points(d, &vol, points.min(POINTS_PER_DISPATCH), seed ^ 0xB41C);
            pts.extend(brick_face_points(d, &vol, &base, b.edge));
        }
        let got = hev.eval(&pts)?;
        t.check(d, &vol, &pts, &got);
        hessian_tally = Some(t);
    }
    let passed = tally.passed() && hessian_tally.as_ref().is_none_or(|t| t.passed());
    Ok(VerifyReport {
        filter: d.filter.name.clone(),
        layout,
        variant,
        form: used,
        bounds,
        fetch,
        points,
        max_abs_err: tally.max_abs,
        max_rel_grad_err: tally.max_rel,
        data_range: range,
        near_knot_points: tally.near_knot_points,
        accepted_other_side: tally.accepted_other_side,
        hessian_form: module.stats.hessian_form,
        max_rel_hessian_err: hessian_tally.as_ref().map(|t| t.max_rel.max(t.first_order.max_rel)),
        hessian_accepted_other_side: hessian_tally.as_ref().map_or(0, |t| t.accepted_other_side),
        passed,
        adapter: gpu.describe(),
    })
}
