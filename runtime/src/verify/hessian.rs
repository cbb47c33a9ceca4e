//! `verify` of `<f>_eval_hessian`: value, gradient and Hessian on the device
//! against the exact evaluator's ([`Derivation::eval_f64_hessian`]), at the
//! same random points as `eval`. Across a knot plane the Hessian of a C^1
//! filter jumps: a point within [`knot_tolerance`](super::knot_tolerance) of
//! a plane passes when it matches the piece on either side (counted), never
//! with a looser tolerance.

use super::exact::{near_knot, Tally};
use super::{kernel, POINTS_PER_DISPATCH};
use crate::gpu::{Gpu, GpuError};
use crate::volume::{DeviceVolume, LatticeVolume};
use boxforge::derive::Derivation;
use boxforge::eval::SecondOrder;

/// Hessian tolerance: |H_gpu - H_exact|_max / max(|H_exact|_max, data range) <= this.
pub const HESSIAN_TOLERANCE: f64 = 1e-4;

/// The compute wrapper: `<name>_eval_hessian` at every point, as four rows
/// (value, gradient) and the Hessian's three columns (all nine entries, so
/// an asymmetric Hessian fails too).
fn wrapper(name: &str) -> String {
    let rows = format!(
        "
fn verify_hessian_rows(p: vec3<f32>) -> array<vec4<f32>, 4> {{
    let r = {name}_eval_hessian(p);
    let h = r.hessian;
    return array<vec4<f32>, 4>(
        vec4<f32>(r.value, r.gradient),
        vec4<f32>(h[0], 0.0),
        vec4<f32>(h[1], 0.0),
        vec4<f32>(h[2], 0.0),
    );
}}
"
    );
    let kernel = kernel::points_kernel(
        "verify_hessian_main",
        1,
        "vh",
        &[kernel::Output { name: "rows", ty: "array<vec4<f32>, 4>", expr: "verify_hessian_rows(p)" }],
    );
    format!("{rows}{kernel}")
}

/// One device result: value, gradient, and the Hessian row-major 3 x 3.
#[derive(Clone, Debug, PartialEq)]
pub struct DeviceSecondOrder {
    pub value: f32,
    pub gradient: [f32; 3],
    pub hessian: [[f32; 3]; 3],
}

impl DeviceSecondOrder {
    /// From the wrapper's rows: r[1 + c][r] is row r of column c.
    fn from_rows(r: &[f32; 16]) -> DeviceSecondOrder {
        DeviceSecondOrder {
            value: r[0],
            gradient: [r[1], r[2], r[3]],
            hessian: std::array::from_fn(|row| std::array::from_fn(|col| r[4 * (1 + col) + row])),
        }
    }
}

/// `<name>_eval_hessian` of a module, compiled once, run on any number of points.
pub struct HessianEvaluator<'a> {
    gpu: &'a Gpu,
    pipeline: wgpu::ComputePipeline,
    bgl1: wgpu::BindGroupLayout,
    bg0: wgpu::BindGroup,
}

impl<'a> HessianEvaluator<'a> {
    /// Compiles `module_source` (which defines `<name>_eval_hessian`) with
    /// the wrapper, its samples bound as `vol` at group 0.
    pub fn new(
        gpu: &'a Gpu,
        module_source: &str,
        label: &str,
        name: &str,
        vol: &DeviceVolume,
    ) -> Result<HessianEvaluator<'a>, GpuError> {
        let source = format!("{module_source}\n{}", wrapper(name));
        let (pipeline, bgl1, bg0) = super::points_pipeline(gpu, &source, label, vol, 1, "verify_hessian_main")?;
        Ok(HessianEvaluator { gpu, pipeline, bgl1, bg0 })
    }

    /// Value, gradient and Hessian at every point.
    pub fn eval(&self, points: &[[f32; 4]]) -> Result<Vec<DeviceSecondOrder>, GpuError> {
        let mut out = Vec::with_capacity(points.len());
        for chunk in points.chunks(POINTS_PER_DISPATCH) {
            out.extend(self.eval_chunk(chunk)?);
        }
        Ok(out)
    }

    fn eval_chunk(&self, points: &[[f32; 4]]) -> Result<Vec<DeviceSecondOrder>, GpuError> {
        let (gpu, dev) = (self.gpu, &self.gpu.device);
        let n = points.len();
        let pts = gpu.storage_buffer("points", bytemuck::cast_slice(points), false);
        let rows = gpu.storage_buffer("hessian rows", &vec![0u8; n * 64], true);
        let bg1 = gpu.checked("bind the points", || {
            dev.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("io"),
                layout: &self.bgl1,
                entries: &[
                    wgpu::BindGroupEntry { binding: 0, resource: pts.as_entire_binding() },
                    wgpu::BindGroupEntry { binding: 1, resource: rows.as_entire_binding() },
                ],
            })
        })?;
        let (gx, gy) = kernel::dispatch_size(n);
        gpu.dispatch("verify hessian", &self.pipeline, &[&self.bg0, &bg1], (gx, gy, 1))?;
        let raw = gpu.read_buffer(&rows)?;
        Ok(bytemuck::cast_slice::<u8, [f32; 16]>(&raw).iter().map(DeviceSecondOrder::from_rows).collect())
    }
}

/// Exact (f64) value, gradient and Hessian at the points, on all cores.
pub fn cpu_eval_hessian(d: &Derivation, vol: &LatticeVolume, points: &[[f32; 4]]) -> Vec<SecondOrder> {
    let data = |j: &[i64]| vol.get(j) as f64;
    let _ = d.f64_tables();
    crate::par::par_map(points, |p| d.eval_f64_hessian(&[p[0] as f64, p[1] as f64, p[2] as f64], &data))
}

/// The running comparison of device Hessians against the exact evaluator.
#[derive(Clone, Debug, Default)]
pub struct HessianTally {
    /// Value and gradient of `eval_hessian`, held to `eval_grad`'s tolerances.
    pub first_order: Tally,
    /// max over points of |H_gpu - H_exact|_max / max(|H_exact|_max, data range).
    pub max_rel: f64,
    /// Near-knot points matched by a neighbouring piece, not the evaluator's own.
    pub accepted_other_side: usize,
}

impl HessianTally {
    pub fn new(data_range: f64) -> HessianTally {
        HessianTally { first_order: Tally::new(data_range), ..HessianTally::default() }
    }

    /// (value error, gradient error, Hessian error) against one exact result.
    fn errors(&self, r: &DeviceSecondOrder, e: &SecondOrder) -> (f64, f64, f64) {
        let g = [r.value, r.gradient[0], r.gradient[1], r.gradient[2]];
        let (abs, rel) = self.first_order.errors(r.value, &g, e.0, &e.1);
        let hmax = e.2.iter().fold(0f64, |m, x| m.max(x.abs()));
        let mut diff = 0f64;
        for i in 0..3 {
            for j in 0..3 {
                diff = diff.max((r.hessian[i][j] as f64 - e.2[i * 3 + j]).abs());
            }
        }
        (abs, rel, diff / hmax.max(self.first_order.data_range))
    }

    fn within(&self, (abs, rel, h): (f64, f64, f64)) -> bool {
        self.first_order.within((abs, rel)) && h <= HESSIAN_TOLERANCE
    }

    /// Compares device results at `pts` with the exact evaluator, with the
    /// knot-plane rule of [`Tally::check`].
    pub fn check(&mut self, d: &Derivation, vol: &LatticeVolume, pts: &[[f32; 4]], got: &[DeviceSecondOrder]) {
        let exact = cpu_eval_hessian(d, vol, pts);
        let data = |j: &[i64]| vol.get(j) as f64;
        for ((p, r), e) in pts.iter().zip(got).zip(&exact) {
            let mut err = self.errors(r, e);
            let x = [p[0] as f64, p[1] as f64, p[2] as f64];
            if let Some(tol) = near_knot(d, &x) {
                self.first_order.near_knot_points += 1;
                if !self.within(err) {
                    let other = d
                        .eval_f64_pieces_near_hessian(&x, &data, tol)
                        .iter()
                        .map(|o| self.errors(r, o))
                        .find(|e| self.within(*e));
                    if let Some(e) = other {
                        self.accepted_other_side += 1;
                        err = e;
                    }
                }
            }
            self.first_order.max_abs = self.first_order.max_abs.max(err.0);
            self.first_order.max_rel = self.first_order.max_rel.max(err.1);
            self.max_rel = self.max_rel.max(err.2);
        }
        self.first_order.points += pts.len();
    }

    /// Every point within the value, gradient and Hessian tolerances.
    pub fn passed(&self) -> bool {
        self.first_order.passed() && self.max_rel <= HESSIAN_TOLERANCE
    }
}
