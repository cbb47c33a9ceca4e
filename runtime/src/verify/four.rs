//! `verify` in four dimensions: the emitted 4D module (samples in a storage
//! buffer, `vec4` points) on the device against the exact evaluator at
//! random points of a random 4D volume: value (`eval`), value and gradient
//! (`eval_grad`, a `<f>_Gradient` struct in 4D) and, from degree 2,
//! `eval_hessian`, with the 3D tolerances and the same acceptance of points
//! within rounding of a knot plane.

use super::exact::{near_knot, GRADIENT_TOLERANCE, VALUE_TOLERANCE};
use super::hessian::HESSIAN_TOLERANCE;
use super::inputs::Rng;
use super::{kernel, VerifyError, VerifyReport};
use crate::gpu::binding::storage_entry;
use crate::gpu::Gpu;
use crate::volume::{DeviceVolume4, LatticeVolume4};
use boxforge::derive::Derivation;
use boxforge::emit::{emit, Bounds, EmitOptions, EvalForm, FetchMode, Layout, Variant};
use boxforge::eval::SecondOrder;

/// Rows of 4 floats the kernel writes per point: (eval, eval_grad.value,
/// eval_hessian.value, 0), eval_grad's gradient, eval_hessian's gradient,
/// then its four columns.
const ROWS: usize = 7;

/// Random data in [0, 1) at the lattice points of a 4D box big enough for the support.
pub fn random_volume4(d: &Derivation, seed: u64) -> LatticeVolume4 {
    let n = (2 * crate::volume::support_radius(d) + 6).next_multiple_of(2);
    let dims = [n; 4];
    let mut rng = Rng(seed);
    let mut data = vec![0f32; n * n * n * n];
    for (i, v) in data.iter_mut().enumerate() {
        let j = [i % n, (i / n) % n, (i / (n * n)) % n, i / (n * n * n)].map(|x| x as i64);
        if d.filter.lattice.contains(&j) {
            *v = rng.next_f64() as f32;
        }
    }
    LatticeVolume4::new(d.filter.lattice.clone(), dims, data).expect("a 4D lattice and a matching box")
}

/// Random points where the whole support lies inside the volume.
pub fn random_points4(d: &Derivation, vol: &LatticeVolume4, count: usize, seed: u64) -> Vec<[f32; 4]> {
    let r = crate::volume::support_radius(d) as f64 + 1.0;
    let mut rng = Rng(seed ^ 0x4D4D);
    (0..count)
        .map(|_| std::array::from_fn(|a| (r + rng.next_f64() * (vol.dims[a] as f64 - 1.0 - 2.0 * r)) as f32))
        .collect()
}

/// The wrapper around the module: one row block per point.
fn wrapper(name: &str, hessian: bool) -> String {
    let h = if hessian {
        format!(
            "    let h = {name}_eval_hessian(p);
    return array<vec4<f32>, {ROWS}>(vec4<f32>({name}_eval(p), g.value, h.value, 0.0), g.gradient, h.gradient,
        h.hessian[0], h.hessian[1], h.hessian[2], h.hessian[3]);"
        )
    } else {
        format!(
            "    let z = vec4<f32>(0.0);
    return array<vec4<f32>, {ROWS}>(vec4<f32>({name}_eval(p), g.value, g.value, 0.0), g.gradient, g.gradient, z, z, z, z);"
        )
    };
    let rows = format!(
        "\nfn verify4_rows(p: vec4<f32>) -> array<vec4<f32>, {ROWS}> {{\n    let g = {name}_eval_grad(p);\n{h}\n}}\n"
    );
    let k = kernel::points_kernel_in(
        4,
        "verify4_main",
        1,
        "v4",
        &[kernel::Output { name: "rows", ty: &format!("array<vec4<f32>, {ROWS}>"), expr: "verify4_rows(p)" }],
    );
    format!("{rows}{k}")
}

/// One point's device results.
#[derive(Clone, Debug, PartialEq)]
pub struct Got4 {
    /// `eval`.
    pub value: f32,
    /// `eval_grad`'s value.
    pub grad_value: f32,
    /// `eval_hessian`'s value (`eval_grad`'s below degree 2).
    pub hessian_value: f32,
    /// `eval_grad`'s gradient.
    pub gradient: [f32; 4],
    /// `eval_hessian`'s gradient (`eval_grad`'s below degree 2).
    pub hessian_gradient: [f32; 4],
    /// Column-major: hessian\[col\]\[row\] (zero below degree 2).
    pub hessian: [[f32; 4]; 4],
}

fn errors(g: &Got4, e: &SecondOrder, range: f64, with_hessian: bool) -> (f64, f64, f64) {
    let (ev, eg, eh) = (e.0, &e.1, &e.2);
    let abs = [g.value, g.grad_value, g.hessian_value].iter().fold(0f64, |m, v| m.max((*v as f64 - ev).abs()));
    let gmax = eg.iter().fold(0f64, |m, x| m.max(x.abs())).max(range);
    let rel = [g.gradient, g.hessian_gradient]
        .iter()
        .flat_map(|gr| (0..4).map(move |i| (gr[i] as f64 - eg[i]).abs()))
        .fold(0f64, f64::max)
        / gmax;
    let h = if with_hessian {
        let hmax = eh.iter().fold(0f64, |m, x| m.max(x.abs())).max(range);
        (0..16).map(|k| (g.hessian[k / 4][k % 4] as f64 - eh[(k % 4) * 4 + k / 4]).abs()).fold(0f64, f64::max) / hmax
    } else {
        0.0
    };
    (abs, rel, h)
}

fn within((abs, rel, h): (f64, f64, f64), range: f64) -> bool {
    abs <= VALUE_TOLERANCE * range && rel <= GRADIENT_TOLERANCE && h <= HESSIAN_TOLERANCE
}

/// A compiled 4D module with the evaluation wrapper, over one 4D volume.
pub struct Evaluator4<'a> {
    gpu: &'a Gpu,
    pipeline: wgpu::ComputePipeline,
    bgl1: wgpu::BindGroupLayout,
    bg0: wgpu::BindGroup,
    /// The emitted module's counts (form, Hessian form).
    pub stats: boxforge::emit::EmitStats,
}

impl<'a> Evaluator4<'a> {
    /// Emits `d` for `dv`'s layout and compiles it with the wrapper.
    pub fn new(
        gpu: &'a Gpu,
        d: &Derivation,
        dv: &DeviceVolume4,
        variant: Variant,
        form: Option<EvalForm>,
        bounds: Bounds,
    ) -> Result<Evaluator4<'a>, VerifyError> {
        let module = emit(
            d,
            &EmitOptions {
                layout: dv.layout,
                variant,
                kernels: false,
                command: "boxforge verify".into(),
                form,
                bounds,
                ..Default::default()
            },
        )?;
        let source = format!("{}\n{}", module.source, wrapper(&d.filter.name, module.stats.hessian_form.is_some()));
        let shader = gpu.compile(&module.file_name, &source)?;
        let dev = &gpu.device;
        let (bgl0, bg0) = dv.group(gpu)?;
        let bgl1 = dev.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("io"),
            entries: &[storage_entry(0, true), storage_entry(1, false)],
        });
        let pipeline = gpu.pipeline("verify4_main", &shader, &[&bgl0, &bgl1], "verify4_main")?;
        Ok(Evaluator4 { gpu, pipeline, bgl1, bg0, stats: module.stats })
    }

    /// Every function of the module at every point.
    pub fn eval(&self, points: &[[f32; 4]]) -> Result<Vec<Got4>, VerifyError> {
        let (gpu, dev) = (self.gpu, &self.gpu.device);
        let mut got = Vec::with_capacity(points.len());
        for chunk in points.chunks(super::POINTS_PER_DISPATCH) {
            let n = chunk.len();
            let pbuf = gpu.storage_buffer("points", bytemuck::cast_slice(chunk), false);
            let out = gpu.storage_buffer("rows", &vec![0u8; n * ROWS * 16], true);
            let bg1 = gpu.checked("bind the points", || {
                dev.create_bind_group(&wgpu::BindGroupDescriptor {
                    label: Some("io"),
                    layout: &self.bgl1,
                    entries: &[
                        wgpu::BindGroupEntry { binding: 0, resource: pbuf.as_entire_binding() },
                        wgpu::BindGroupEntry { binding: 1, resource: out.as_entire_binding() },
                    ],
                })
            })?;
            let (gx, gy) = kernel::dispatch_size(n);
            gpu.dispatch("verify4", &self.pipeline, &[&self.bg0, &bg1], (gx, gy, 1))?;
            let raw = gpu.read_buffer(&out)?;
            got.extend(bytemuck::cast_slice::<u8, [[f32; 4]; ROWS]>(&raw).iter().map(|r| Got4 {
                value: r[0][0],
                grad_value: r[0][1],
                hessian_value: r[0][2],
                gradient: r[1],
                hessian_gradient: r[2],
                hessian: [r[3], r[4], r[5], r[6]],
            }));
        }
        Ok(got)
    }
}

/// The comparison of device results with the exact evaluator in 4D.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Tally4 {
    pub data_range: f64,
    pub max_abs: f64,
    pub max_rel: f64,
    /// Largest relative Hessian error (0 below degree 2).
    pub max_rel_hessian: f64,
    pub near_knot_points: usize,
    pub accepted_other_side: usize,
}

impl Tally4 {
    /// Device results `got` at `pts` against the exact values on `vol`
    /// (value, gradient and, `with_hessian`, the Hessian; a point within
    /// rounding of a knot plane may match the piece across it).
    pub fn check(d: &Derivation, vol: &LatticeVolume4, pts: &[[f32; 4]], got: &[Got4], with_hessian: bool) -> Tally4 {
        let data = |j: &[i64]| vol.get(j) as f64;
        let _ = d.f64_tables();
        let exact: Vec<SecondOrder> = crate::par::par_map(pts, |p| d.eval_f64_hessian(&p.map(f64::from), &data));
        let (lo, hi) = vol.data.iter().fold((f32::INFINITY, f32::NEG_INFINITY), |(a, b), &v| (a.min(v), b.max(v)));
        let range = (hi - lo).max(f32::MIN_POSITIVE) as f64;
        let mut t = Tally4 { data_range: range, ..Tally4::default() };
        for ((p, g), e) in pts.iter().zip(got).zip(&exact) {
            let mut err = errors(g, e, range, with_hessian);
            let x = p.map(f64::from);
            if let Some(tol) = near_knot(d, &x) {
                t.near_knot_points += 1;
                if !within(err, range) {
                    let found = d
                        .eval_f64_pieces_near_hessian(&x, &data, tol)
                        .iter()
                        .map(|o| errors(g, o, range, with_hessian))
                        .find(|e| within(*e, range));
                    if let Some(e) = found {
                        t.accepted_other_side += 1;
                        err = e;
                    }
                }
            }
            t.max_abs = t.max_abs.max(err.0);
            t.max_rel = t.max_rel.max(err.1);
            t.max_rel_hessian = t.max_rel_hessian.max(err.2);
        }
        t
    }

    /// Every point within the value, gradient and Hessian tolerances.
    pub fn passed(&self) -> bool {
        within((self.max_abs, self.max_rel, self.max_rel_hessian), self.data_range)
    }
}

/// [`super::verify_fetch`] for a 4D filter (exact fetches: 4D samples are a
/// storage buffer, which no sampler filters).
#[allow(clippy::too_many_arguments)]
pub fn verify4(
    gpu: &Gpu,
    d: &Derivation,
    layout: Layout,
    variant: Variant,
    form: Option<EvalForm>,
    bounds: Bounds,
    points: usize,
    seed: u64,
) -> Result<VerifyReport, VerifyError> {
    if points == 0 {
        return Err(VerifyError::NoPoints);
    }
    let vol = random_volume4(d, seed);
    let dv = DeviceVolume4::new(gpu, &vol, layout)?;
    let ev = Evaluator4::new(gpu, d, &dv, variant, form, bounds)?;
    let with_hessian = ev.stats.hessian_form.is_some();
    let pts = random_points4(d, &vol, points, seed);
    let got = ev.eval(&pts)?;
    let t = Tally4::check(d, &vol, &pts, &got, with_hessian);
    Ok(VerifyReport {
        filter: d.filter.name.clone(),
        layout,
        variant,
        form: ev.stats.form,
        bounds,
        fetch: FetchMode::Exact,
        points,
        max_abs_err: t.max_abs,
        max_rel_grad_err: t.max_rel,
        data_range: t.data_range,
        near_knot_points: t.near_knot_points,
        accepted_other_side: t.accepted_other_side,
        hessian_form: ev.stats.hessian_form,
        max_rel_hessian_err: with_hessian.then_some(t.max_rel_hessian),
        hessian_accepted_other_side: if with_hessian { t.accepted_other_side } else { 0 },
        passed: t.passed(),
        adapter: gpu.describe(),
    })
}
