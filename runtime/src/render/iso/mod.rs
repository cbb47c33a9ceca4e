//! Isosurface rendering: the emitted filter module plus the ray-casting
//! template (`templates/raycast.wgsl.j2`), the BB min/max block grid from the
//! emitted min/max kernel, and a CPU reference ray caster for tests.

pub mod renderer;
use crate::gpu::binding::{storage_entry, uniform_entry};
use crate::gpu::{Gpu, GpuError};
use crate::render::blocks::{self, block_bounds};
use crate::volume::DeviceVolume;
use crate::volume::LatticeVolume;
use boxforge::derive::Derivation;
use boxforge::emit::{emit, EmitOptions, Layout};
use glam::{DVec3, Vec3};

#[derive(Clone, Debug)]
pub struct RenderOptions {
    pub iso: f32,
    pub width: u32,
    pub height: u32,
    /// View azimuth and elevation in degrees.
    pub azimuth: f32,
    pub elevation: f32,
    pub perspective: bool,
    /// Empty-space skipping with the min/max block grid.
    pub skip: bool,
    /// Ray step in cells.
    pub step: f32,
    /// Block edge in unit cubes.
    pub block: i32,
    /// Frames to time after one warm-up frame.
    pub frames: usize,
    /// Render in bands of rows and report progress on stderr (for long renders).
    pub progress: bool,
    /// How a ray finds the surface: exactly, piece by piece, or by fixed steps.
    pub hit: HitMode,
}

/// How the ray caster finds the first iso-surface crossing along a ray.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum HitMode {
    /// Piece by piece: the ray is cut at every grid and knot plane, the
    /// spline on each segment is one polynomial of the filter's degree whose
    /// Bernstein coefficients (from degree + 1 samples) exclude the segment
    /// or lead to its first root by Bernstein subdivision. Finds thin
    /// features that fixed steps jump over.
    Exact,
    /// Fixed steps of `step` cells with a sign test, then bisection (the
    /// library default, so existing callers and bench rows keep their meaning).
    #[default]
    Step,
}

impl HitMode {
    /// `exact` or `step`.
    pub fn parse(s: &str) -> Option<HitMode> {
        match s {
            "exact" => Some(HitMode::Exact),
            "step" => Some(HitMode::Step),
            _ => None,
        }
    }

    /// The name `parse` accepts.
    pub fn as_str(self) -> &'static str {
        match self {
            HitMode::Exact => "exact",
            HitMode::Step => "step",
        }
    }
}

impl Default for RenderOptions {
    fn default() -> Self {
        RenderOptions {
            iso: 0.5,
            width: 256,
            height: 256,
            azimuth: 30.0,
            elevation: 25.0,
            perspective: false,
            skip: true,
            step: 0.25,
            block: 4,
            frames: 3,
            progress: false,
            hit: HitMode::default(),
        }
    }
}

/// The uniform block of the ray caster (layout checked against naga in tests).
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
pub struct RayParams {
    /// Eye, view and valid box (the block every ray caster starts with).
    pub camera: crate::render::camera::CameraUniform,
    pub shade: [f32; 4],
    pub image: [i32; 4],
    pub blocks: [i32; 4],
}

/// `p.eye` and the other camera fields read through to [`RayParams::camera`]
/// (the iso code written before the camera block was shared).
impl std::ops::Deref for RayParams {
    type Target = crate::render::camera::CameraUniform;
    fn deref(&self) -> &Self::Target {
        &self.camera
    }
}

pub struct Frame {
    pub width: u32,
    pub height: u32,
    /// RGBA8, row-major from the top.
    pub rgba: Vec<u8>,
    /// Median wall time of the timed frames (submit + wait), in ms.
    pub ms_per_frame: f64,
    /// Fraction of blocks whose bounds exclude the iso-value.
    pub empty_blocks: f64,
}

/// The xyz of a uniform vector, widened to f64 (exactly).
fn d3(a: [f32; 4]) -> DVec3 {
    Vec3::from_slice(&a[..3]).as_dvec3()
}

/// [`valid_box`] as glam vectors.
fn valid_box_vec(d: &Derivation, vol: &LatticeVolume) -> (Vec3, Vec3) {
    box_of(crate::verify::support_radius(d), vol.dims)
}

/// The valid box of a volume of `dims` samples for a support of `radius` cells.
fn box_of(radius: usize, dims: [usize; 3]) -> (Vec3, Vec3) {
    let r = radius as f32;
    let dims = Vec3::new(dims[0] as f32, dims[1] as f32, dims[2] as f32);
    (Vec3::splat(r), dims - 1.0 - r)
}

/// The box where the whole support of every sample used lies in the volume.
pub fn valid_box(d: &Derivation, vol: &LatticeVolume) -> ([f32; 3], [f32; 3]) {
    let (lo, hi) = valid_box_vec(d, vol);
    (lo.to_array(), hi.to_array())
}

/// The camera's forward direction (from the eye toward the volume) for an
/// azimuth and elevation in degrees: what view-dependent filters follow.
pub fn view_direction(azimuth: f32, elevation: f32) -> [f64; 3] {
    let (az, el) = (azimuth.to_radians(), elevation.to_radians());
    let toward_eye = Vec3::new(el.cos() * az.cos(), el.cos() * az.sin(), el.sin());
    (-toward_eye).to_array().map(f64::from)
}

pub fn ray_params(d: &Derivation, vol: &LatticeVolume, o: &RenderOptions) -> RayParams {
    ray_params_for(crate::verify::support_radius(d), vol.dims, o)
}

/// [`ray_params`] for a volume of `dims` samples and a filter whose support
/// reaches `radius` cells (what a renderer keeps after the upload).
pub(crate) fn ray_params_for(radius: usize, dims: [usize; 3], o: &RenderOptions) -> RayParams {
    let (lo, hi) = box_of(radius, dims);
    let camera = crate::render::Camera { azimuth: o.azimuth, elevation: o.elevation, perspective: o.perspective };
    let blocks = [
        (dims[0] as i32 + o.block - 1) / o.block,
        (dims[1] as i32 + o.block - 1) / o.block,
        (dims[2] as i32 + o.block - 1) / o.block,
        0,
    ];
    RayParams {
        camera: crate::render::camera::CameraUniform::orbit(&camera, lo.to_array(), hi.to_array(), o.width, o.height),
        shade: [o.iso, o.step, o.perspective as i32 as f32, o.skip as i32 as f32],
        image: [o.width as i32, o.height as i32, o.block, 0],
        blocks,
    }
}

/// Segments shorter than this (in cells) merge into the next one: planes
/// that cross the ray this close together are one cut (both walks).
pub const HIT_MERGE: f64 = 1e-5;
/// Deepest Bernstein subdivision level of the first-root search.
pub const HIT_DEPTH: i32 = 10;
/// Subdivision steps of the first-root search before it gives up (a miss).
pub const HIT_ITERATIONS: usize = 64;
/// Root tolerance in cells (as the fixed-step bisection).
pub const HIT_TOLERANCE: f64 = 1e-4;

/// What the exact first-hit walk needs from a filter: the planes that cut a
/// ray into polynomial pieces, and the conversion from samples on a segment
/// to the Bernstein coefficients of that piece.
#[derive(Clone, Debug)]
pub struct HitPlan {
    /// Plane families n . x in offset + period Z: the grid planes x_i in o_i + Z
    /// and every knot-plane family that is not an axis (axis knot planes are
    /// grid planes). Between two consecutive crossings the ray stays in one cell.
    pub families: Vec<([f64; 3], f64, f64)>,
    /// The grid offset o (cubes are o + z + `[0,1]^3`).
    pub grid_offset: [f64; 3],
    /// The filter's degree: the degree of the spline on every segment.
    pub degree: usize,
    /// Where a segment is sampled (u in `[0,1]`) and whether the sample also
    /// takes the derivative along the ray (from `_eval_grad`, which costs
    /// about one `_eval`): together degree + 1 conditions.
    pub samples: Vec<(f64, bool)>,
    /// Whether the samples start at u = 0 and end at u = 1, so that the end
    /// sample of one segment is the start sample of the next (continuous
    /// splines; with derivatives only for C^1 and smoother ones).
    pub shared_ends: bool,
    /// `to_bernstein[j][c]`: weight of condition c (each sample's value, then
    /// its derivative d/du if taken) in Bernstein coefficient j.
    pub to_bernstein: Vec<Vec<f64>>,
    /// For C^2 splines of even degree: the segment after an evaluated one
    /// may take the second derivative at its start from the previous
    /// segment's polynomial (the spline is C^2 across every plane), one
    /// sample fewer. `carried_samples` are its interior samples (value and
    /// derivative each), `carried_to_bernstein` the conversion of the
    /// conditions [v0, d0, s0 (d²/du²), interior..., v1, d1].
    pub carried_samples: Vec<f64>,
    /// See `carried_samples`; empty when segments never carry.
    pub carried_to_bernstein: Vec<Vec<f64>>,
    /// For filters whose unit cubes are single polynomial pieces and whose
    /// only cutting planes are the grid planes (cc_trilinear, cc_tricubic):
    /// the WGSL of `<f>_ray_bernstein`, which gives a segment's Bernstein
    /// coefficients from one set of fetches by blossoming instead of the
    /// samples above (`boxforge::emit::factored::ray_bernstein_fn`). The
    /// polynomial is the same; the CPU reference keeps sampling it.
    pub ray_bernstein: Option<String>,
}

/// A carried second derivative s = d²f/dt² passes from segment to segment
/// unchanged in t units (for Hermite data v0, d0, s0, v1, d1 the end value
/// p''(1) depends on s0 with weight exactly 1), so the rounding error that a
/// fresh or carried segment k puts into s, about e / len_k², reaches segment
/// m as e (len_m / len_k)² in its coefficients. A segment carries only while
/// len_m² * sum_k 1 / len_k² (over the chain since the last fresh segment)
/// stays at most this bound: the error stays within this many roundings of
/// one segment, whatever the segment lengths (a short segment makes the next
/// long one start fresh).
pub const HIT_CARRY_BOUND: f64 = 8.0;

impl HitPlan {
    /// The plan of a 3D filter. C^1 splines of degree >= 3 sample value and
    /// derivative at both ends and (n - 3) more conditions at interior
    /// Chebyshev points (Hermite data: about half the samples of values only);
    /// other continuous splines values at the Chebyshev extrema; discontinuous
    /// ones values at the Chebyshev roots inside (0,1), off the knot planes.
    pub fn new(d: &Derivation) -> HitPlan {
        let arr = &d.arrangement;
        let grid_offset = [0, 1, 2].map(|i| arr.grid_offset[i].to_f64());
        let mut families: Vec<([f64; 3], f64, f64)> = (0..3)
            .map(|i| {
                let mut n = [0.0; 3];
                n[i] = 1.0;
                (n, grid_offset[i], 1.0)
            })
            .collect();
        for f in &arr.families {
            if f.normal.iter().filter(|&&c| c != 0).count() > 1 {
                families.push(([0, 1, 2].map(|i| f.normal[i] as f64), f.offset.to_f64(), f.period as f64));
            }
        }
        let n = d.facts.degree;
        let pi = std::f64::consts::PI;
        let cheb = |k: usize, m: usize| 0.5 * (1.0 - (pi * k as f64 / m as f64).cos());
        let (samples, shared_ends): (Vec<(f64, bool)>, bool) = if d.facts.continuity >= 1 && n >= 3 {
            let r = n - 3;
            let m = r.div_ceil(2);
            let mut v = vec![(0.0, true)];
            v.extend((1..=m).map(|k| (cheb(k, m + 1), !(r % 2 == 1 && k == m))));
            v.push((1.0, true));
            (v, true)
        } else if d.facts.continuity >= 0 && n > 0 {
            ((0..=n).map(|i| (if i == n { 1.0 } else { cheb(i, n) }, false)).collect(), true)
        } else {
            (
                (0..=n).map(|i| (0.5 * (1.0 - (pi * (2 * i + 1) as f64 / (2 * n + 2) as f64).cos()), false)).collect(),
                false,
            )
        };
        let mut m: Vec<Vec<f64>> = Vec::new();
        for &(x, grad) in &samples {
            m.push((0..=n).map(|j| bernstein(n, j, x)).collect());
            if grad {
                m.push((0..=n).map(|j| bernstein_du(n, j, x)).collect());
            }
        }
        assert_eq!(m.len(), n + 1, "degree + 1 conditions");
        let (mut carried_samples, mut carried_to_bernstein) = (vec![], vec![]);
        if d.facts.continuity >= 2 && n >= 4 && n.is_multiple_of(2) {
            let k = (n - 4) / 2;
            carried_samples = (1..=k).map(|i| cheb(i, k + 1)).collect();
            let mut rows: Vec<Vec<f64>> = vec![
                (0..=n).map(|j| bernstein(n, j, 0.0)).collect(),
                (0..=n).map(|j| bernstein_du(n, j, 0.0)).collect(),
                (0..=n).map(|j| bernstein_du2(n, j, 0.0)).collect(),
            ];
            for &x in &carried_samples {
                rows.push((0..=n).map(|j| bernstein(n, j, x)).collect());
                rows.push((0..=n).map(|j| bernstein_du(n, j, x)).collect());
            }
            rows.push((0..=n).map(|j| bernstein(n, j, 1.0)).collect());
            rows.push((0..=n).map(|j| bernstein_du(n, j, 1.0)).collect());
            assert_eq!(rows.len(), n + 1, "degree + 1 conditions");
            carried_to_bernstein = invert(&rows);
        }
        let ray_bernstein =
            if families.len() == 3 { boxforge::emit::factored::ray_bernstein_fn(d, &d.filter.name) } else { None };
        HitPlan {
            ray_bernstein,
            families,
            grid_offset,
            degree: n,
            samples,
            shared_ends,
            to_bernstein: invert(&m),
            carried_samples,
            carried_to_bernstein,
        }
    }

    /// Bernstein coefficients on `[0,1]` from the conditions (values and
    /// derivatives d/du in the order of `samples`).
    pub fn coefficients(&self, conditions: &[f64]) -> Vec<f64> {
        self.coefficients_with(&self.to_bernstein, conditions)
    }

    /// Bernstein coefficients from conditions through a conversion matrix.
    pub fn coefficients_with(&self, m: &[Vec<f64>], conditions: &[f64]) -> Vec<f64> {
        m.iter().map(|row| row.iter().zip(conditions).map(|(w, v)| w * v).sum()).collect()
    }

    /// Samples per segment that call the evaluator (shared ends not counted).
    pub fn evals_per_segment(&self) -> usize {
        self.samples.len() - self.shared_ends as usize
    }
}

/// The Bernstein basis polynomial B_j^n(x).
fn bernstein(n: usize, j: usize, x: f64) -> f64 {
    let mut binom = 1.0;
    for k in 0..j {
        binom = binom * (n - k) as f64 / (k + 1) as f64;
    }
    binom * x.powi(j as i32) * (1.0 - x).powi((n - j) as i32)
}

/// d²/dx² B_j^n(x) = n (n - 1) (B_{j-2}^{n-2} - 2 B_{j-1}^{n-2} + B_j^{n-2})(x).
fn bernstein_du2(n: usize, j: usize, x: f64) -> f64 {
    let b = |k: i64| if k >= 0 && k as usize <= n - 2 { bernstein(n - 2, k as usize, x) } else { 0.0 };
    let j = j as i64;
    (n * (n - 1)) as f64 * (b(j - 2) - 2.0 * b(j - 1) + b(j))
}

/// The second derivative d²/dt² at the end of a segment of length `len`
/// from the Bernstein coefficients of its polynomial (in u).
pub fn end_second_derivative(c: &[f64], len: f64) -> f64 {
    let n = c.len() - 1;
    (n * (n - 1)) as f64 * (c[n] - 2.0 * c[n - 1] + c[n - 2]) / (len * len)
}

/// d/dx B_j^n(x) = n (B_{j-1}^{n-1}(x) - B_j^{n-1}(x)).
fn bernstein_du(n: usize, j: usize, x: f64) -> f64 {
    let lower = |k: usize| if k < n { bernstein(n - 1, k, x) } else { 0.0 };
    let left = if j > 0 { lower(j - 1) } else { 0.0 };
    n as f64 * (left - lower(j))
}

/// The inverse of a small well-conditioned matrix (Gauss-Jordan, partial pivoting).
fn invert(m: &[Vec<f64>]) -> Vec<Vec<f64>> {
    let n = m.len();
    let mut a: Vec<Vec<f64>> = m
        .iter()
        .enumerate()
        .map(|(i, row)| {
            let mut r = row.clone();
            r.extend((0..n).map(|j| (i == j) as i32 as f64));
            r
        })
        .collect();
    for col in 0..n {
        let piv = (col..n).max_by(|&x, &y| a[x][col].abs().total_cmp(&a[y][col].abs())).expect("rows");
        a.swap(col, piv);
        let p = a[col][col];
        for v in a[col].iter_mut() {
            *v /= p;
        }
        let pivot = a[col].clone();
        for (r, row) in a.iter_mut().enumerate() {
            let f = row[col];
            if r != col && f != 0.0 {
                for (x, p) in row.iter_mut().zip(&pivot) {
                    *x -= f * p;
                }
            }
        }
    }
    a.into_iter().map(|r| r[n..].to_vec()).collect()
}

/// The polynomial with Bernstein coefficients `c` on `[0,1]` at u (de Casteljau).
pub fn bernstein_at(c: &[f64], u: f64) -> f64 {
    let mut b = c.to_vec();
    for r in 1..b.len() {
        for j in 0..b.len() - r {
            b[j] = (1.0 - u) * b[j] + u * b[j + 1];
        }
    }
    b[0]
}

/// The Bernstein coefficients of the same polynomial on [u0, u1] (0 < u1).
pub fn bernstein_restrict(c: &[f64], u0: f64, u1: f64) -> Vec<f64> {
    let n = c.len() - 1;
    let mut b = c.to_vec();
    let mut left = vec![0.0; n + 1];
    left[0] = b[0];
    for (r, l) in left.iter_mut().enumerate().skip(1) {
        for j in 0..=n - r {
            b[j] = (1.0 - u1) * b[j] + u1 * b[j + 1];
        }
        *l = b[0];
    }
    let s = u0 / u1;
    let mut out = vec![0.0; n + 1];
    out[n] = left[n];
    for r in 1..=n {
        for j in 0..=n - r {
            left[j] = (1.0 - s) * left[j] + s * left[j + 1];
        }
        out[n - r] = left[n - r];
    }
    out
}

/// Sign changes (negative vs not) along the coefficients.
fn variations(c: &[f64]) -> usize {
    c.windows(2).filter(|w| (w[0] < 0.0) != (w[1] < 0.0)).count()
}

/// The first root in `[0,1]` of the polynomial with Bernstein coefficients
/// `c` (of f - iso), to `tol` in u: depth-first, left-first over dyadic
/// intervals, an interval is dropped when its coefficients have one sign,
/// accepted when they change sign once (exactly one root), split otherwise
/// down to [`HIT_DEPTH`]; the root is then bisected on the polynomial. The
/// shader's `_first_root` is the same algorithm in f32.
pub fn first_root(c: &[f64], tol: f64) -> Option<f64> {
    let n = c.len() - 1;
    let (mut l, mut k) = (0i32, 0i64);
    for _ in 0..HIT_ITERATIONS {
        let w = 1.0 / (1i64 << l) as f64;
        let u0 = k as f64 * w;
        let s = if l == 0 { c.to_vec() } else { bernstein_restrict(c, u0, (k + 1) as f64 * w) };
        let v = variations(&s);
        let mut done = v == 0;
        if v == 1 || (v > 0 && l == HIT_DEPTH) {
            if (s[0] < 0.0) != (s[n] < 0.0) {
                let (mut a, mut b) = (0.0, 1.0);
                let sa = s[0] < 0.0;
                for _ in 0..40 {
                    if (b - a) * w <= tol {
                        break;
                    }
                    let m = 0.5 * (a + b);
                    if (bernstein_at(&s, m) < 0.0) == sa {
                        a = m;
                    } else {
                        b = m;
                    }
                }
                return Some(u0 + w * 0.5 * (a + b));
            }
            done = true;
        }
        if !done {
            l += 1;
            k *= 2;
            continue;
        }
        loop {
            if l == 0 {
                return None;
            }
            if k & 1 == 0 {
                k += 1;
                break;
            }
            k >>= 1;
            l -= 1;
        }
    }
    None
}

/// The next t > `t` where a ray with a = n . origin - offset and b = n . dir
/// crosses a plane of a family with this period (infinite when parallel).
fn next_crossing(a: f64, b: f64, period: f64, t: f64) -> f64 {
    if b.abs() <= 1e-9 {
        return f64::INFINITY;
    }
    let q = (a + t * b) / period;
    let k = if b > 0.0 { q.floor() + 1.0 } else { q.ceil() - 1.0 };
    (k * period - a) / b
}

/// f32 literal for WGSL.
fn lit(x: f64) -> String {
    format!("{:?}", x as f32)
}

/// Coefficient expressions c_j = sum_k w_jk names_k.
fn coefficient_exprs(m: &[Vec<f64>], names: &[String]) -> Vec<String> {
    m.iter()
        .map(|row| {
            let terms: Vec<String> = row
                .iter()
                .zip(names)
                .filter(|(w, _)| w.abs() > 1e-12)
                .map(|(&w, v)| if (w - 1.0).abs() < 1e-12 { v.clone() } else { format!("{} * {v}", lit(w)) })
                .collect();
            if terms.is_empty() {
                "0.0".to_string()
            } else {
                terms.join(" + ")
            }
        })
        .collect()
}

/// The minijinja context of the exact walk for this plan: the sampling code
/// of one segment [t, te] (length len; `pv`, `pg`, `ps` the value, d/dt and
/// d²/dt² carried from the previous segment's end when `have`), assigning
/// the Bernstein coefficients c_j, and the carry to the next segment.
fn hit_context(plan: &HitPlan, name: &str) -> minijinja::Value {
    let families: Vec<minijinja::Value> = plan
        .families
        .iter()
        .map(|(n, off, g)| {
            minijinja::context! {
                n => format!("{}, {}, {}", lit(n[0]), lit(n[1]), lit(n[2])),
                off => lit(*off),
                g => lit(*g),
            }
        })
        .collect();
    let n = plan.degree;
    let last = plan.samples.len() - 1;
    let pos = |x: f64| format!("o + (t + len * {}) * dir", lit(x));
    let sample = |code: &mut String, v: &str, dv: &str, p: &str, grad: bool, indent: &str| {
        if grad {
            *code += &format!(
                "{indent}let g{v} = {name}_eval_grad({p});\n{indent}let {v} = g{v}.x - iso;\n{indent}let {dv} = len * dot(g{v}.yzw, dir);\n"
            );
        } else {
            *code += &format!("{indent}let {v} = {name}_eval({p}) - iso;\n");
        }
    };
    let mut code = String::new();
    let mut names = Vec::new();
    let (start_grad, end_grad) = (plan.samples[0].1, plan.samples[last].1);
    if plan.shared_ends {
        let fresh = if start_grad {
            format!("let g = {name}_eval_grad(o + t * dir);\n            pv = g.x - iso;\n            pg = dot(g.yzw, dir);")
        } else {
            format!("pv = {name}_eval(o + t * dir) - iso;")
        };
        code += &format!(
            "        if (!have) {{\n            {fresh}\n            ps = 0.0;\n        }}\n        let v0 = pv;\n"
        );
        if start_grad {
            code += "        let d0 = len * pg;\n";
        }
        sample(&mut code, "ve", "de", "o + te * dir", end_grad, "        ");
    }
    let carry = !plan.carried_to_bernstein.is_empty();
    code += &(0..=n).map(|j| format!("        var c{j} = 0.0;\n")).collect::<String>();
    let mut fresh_code = String::new();
    for (i, &(x, grad)) in plan.samples.iter().enumerate() {
        if plan.shared_ends && i == 0 {
            names.push("v0".to_string());
            if grad {
                names.push("d0".to_string());
            }
        } else if plan.shared_ends && i == last {
            names.push("ve".to_string());
            if grad {
                names.push("de".to_string());
            }
        } else {
            let (v, dv) = (format!("v{i}"), format!("d{i}"));
            sample(&mut fresh_code, &v, &dv, &pos(x), grad, "            ");
            names.push(v);
            if grad {
                names.push(dv);
            }
        }
    }
    for (j, e) in coefficient_exprs(&plan.to_bernstein, &names).iter().enumerate() {
        fresh_code += &format!("            c{j} = {e};\n");
    }
    if carry {
        let mut carried_code = String::from("            let s0 = len * len * ps;\n");
        let mut cnames: Vec<String> = ["v0", "d0", "s0"].map(String::from).to_vec();
        for (k, &x) in plan.carried_samples.iter().enumerate() {
            let (v, dv) = (format!("vc{k}"), format!("dc{k}"));
            sample(&mut carried_code, &v, &dv, &pos(x), true, "            ");
            cnames.push(v);
            cnames.push(dv);
        }
        cnames.push("ve".into());
        cnames.push("de".into());
        for (j, e) in coefficient_exprs(&plan.carried_to_bernstein, &cnames).iter().enumerate() {
            carried_code += &format!("            c{j} = {e};\n");
        }
        code += &format!(
            "        if (have && len * len * acc <= {}) {{\n{carried_code}        }} else {{\n{fresh_code}            acc = 0.0;\n        }}\n",
            lit(HIT_CARRY_BOUND)
        );
    } else {
        code += &format!("        {{\n{fresh_code}        }}\n");
    }
    let mut carry_code = String::new();
    if plan.shared_ends {
        carry_code = "pv = ve;".into();
        if end_grad {
            carry_code += " pg = dot(gve.yzw, dir);";
        }
        if carry {
            carry_code += &format!(
                " ps = {}.0 * (c{n} - 2.0 * c{} + c{}) / (len * len); acc += 1.0 / (len * len);",
                n * (n - 1),
                n - 1,
                n - 2
            );
        }
    }
    if plan.ray_bernstein.is_some() {
        code = format!(
            "        let cb = {name}_ray_bernstein(o + t * dir, o + te * dir, iso);\n{}",
            (0..=n).map(|j| format!("        let c{j} = cb[{j}];\n")).collect::<String>()
        );
        carry_code = String::new();
    }
    minijinja::context! {
        helper => plan.ray_bernstein.clone().unwrap_or_default(),
        families => families,
        degree => n,
        samples => code,
        carry => carry_code,
        grid_offset => format!("{}, {}, {}", lit(plan.grid_offset[0]), lit(plan.grid_offset[1]), lit(plan.grid_offset[2])),
        merge => lit(HIT_MERGE),
        depth => HIT_DEPTH,
        iterations => HIT_ITERATIONS,
        tolerance => lit(HIT_TOLERANCE),
    }
}

/// The ray caster for this filter: the fixed-step walk, or with `exact`
/// the exact walk over a fine bounds grid of `fine` = (edge, blocks per axis).
fn template(name: &str, exact: Option<(&HitPlan, i32, [i32; 3])>) -> String {
    let env = {
        let mut env = minijinja::Environment::new();
        env.add_template("raycast", include_str!("../../../../templates/raycast.wgsl.j2")).expect("template");
        env
    };
    let ctx = match exact {
        Some((plan, edge, blocks)) => minijinja::context! {
            name => name,
            exact => true,
            fine_edge => edge,
            fine_blocks_x => blocks[0],
            fine_blocks_y => blocks[1],
            fine_blocks_z => blocks[2],
            hit => hit_context(plan, name),
        },
        None => minijinja::context! { name => name, exact => false },
    };
    env.get_template("raycast").unwrap().render(ctx).expect("render")
}

/// Renders one isosurface image on the device.
pub fn render(
    gpu: &Gpu,
    d: &Derivation,
    vol: &LatticeVolume,
    layout: Layout,
    o: &RenderOptions,
) -> Result<Frame, GpuError> {
    render_with_depth(gpu, d, vol, layout, o).map(|(frame, _)| frame)
}

/// The whole ray-casting shader of a filter: its emitted module (`command`
/// named in the header) and the ray caster of `hit`. The exact walk's fine
/// bounds grid (edge, blocks per axis) are pipeline-overridable constants
/// with `fine` as their defaults, so the browser viewer runs the same source
/// on any volume (`boxforge web`).
pub fn raycast_shader(
    d: &Derivation,
    layout: Layout,
    hit: HitMode,
    fine: (i32, [i32; 3]),
    command: &str,
) -> Result<String, GpuError> {
    let module = emit(d, &EmitOptions { layout, command: command.into(), ..Default::default() })
        .map_err(|e| GpuError::Runtime(e.to_string()))?;
    let plan = HitPlan::new(d);
    let exact = (hit == HitMode::Exact).then_some((&plan, fine.0, fine.1));
    Ok(format!("{}\n{}", module.source, template(&d.filter.name, exact)))
}

/// The fine grid of the exact walk for a volume of `dims` and coarse blocks
/// of `block` cubes: (edge, blocks per axis); see [`fine_edge`].
pub fn fine_grid(dims: [usize; 3], block: i32) -> (i32, [i32; 3]) {
    let e = fine_edge(dims, block);
    (e, dims.map(|n| n.div_ceil(e as usize) as i32))
}

/// The edge of the fine bounds grid of the exact walk: 1 (one bound per unit
/// cube) unless the grid would need more than 65535 workgroups of 64 to fill.
pub fn fine_edge(dims: [usize; 3], coarse: i32) -> i32 {
    let mut e = 1i32;
    while e < coarse.max(1) {
        let blocks: usize = dims.iter().map(|&n| n.div_ceil(e as usize)).product();
        if blocks.div_ceil(64) <= 65535 {
            break;
        }
        e *= 2;
    }
    e
}

/// [`render`], and the ray parameter t of every pixel's hit (-1 for a miss).
pub fn render_with_depth(
    gpu: &Gpu,
    d: &Derivation,
    vol: &LatticeVolume,
    layout: Layout,
    o: &RenderOptions,
) -> Result<(Frame, Vec<f32>), GpuError> {
    let name = &d.filter.name;
    let params = ray_params(d, vol, o);
    let exact = o.hit == HitMode::Exact;
    let (fine, fine_blocks) = fine_grid(vol.dims, o.block);
    let source = raycast_shader(d, layout, o.hit, (fine, fine_blocks), "boxforge render")?;
    let shader = gpu.compile(&format!("{name}.raycast.wgsl"), &source)?;
    let dev = &gpu.device;
    let dv = DeviceVolume::new(gpu, vol, layout)?;
    let nblocks = (params.blocks[0] * params.blocks[1] * params.blocks[2]) as usize;
    // Min/max block grids with the emitted kernel: blocks of `o.block` cubes,
    // and for the exact walk, which also tests each segment's cube (or small
    // block) on its own, the fine grid.
    let bounds = block_bounds(gpu, &shader, name, &dv, vol.dims, o.block)?;
    let blocks_buf = blocks::upload(gpu, "blocks", &bounds);
    let empty = bounds.iter().filter(|b| o.iso < b[0] || o.iso > b[1]).count() as f64 / nblocks.max(1) as f64;
    let fine_buf = if exact {
        Some(blocks::upload(gpu, "fine blocks", &block_bounds(gpu, &shader, name, &dv, vol.dims, fine)?))
    } else {
        None
    };

    // Ray casting.
    let bgl_s = dev.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
        label: Some("samples"),
        entries: &dv.layout_entries(0, wgpu::ShaderStages::COMPUTE),
    });
    let bgl_rc = dev.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
        label: Some("raycast"),
        entries: &[
            uniform_entry(0),
            storage_entry(1, false),
            storage_entry(2, true),
            storage_entry(3, false),
            storage_entry(4, true),
        ],
    });
    let raycast = gpu.pipeline("raycast", &shader, &[&bgl_s, &bgl_rc], &format!("{name}_raycast_main"))?;
    let pixels = (o.width * o.height) as usize;
    let params_buf = gpu.uniform_buffer("params", bytemuck::bytes_of(&params));
    let image = gpu.storage_buffer("image", &vec![0u8; pixels * 4], true);
    let depth = gpu.storage_buffer("depth", &vec![0u8; pixels * 4], true);
    let bg_s =
        dev.create_bind_group(&wgpu::BindGroupDescriptor { label: None, layout: &bgl_s, entries: &dv.bind_entries(0) });
    let bg_rc = dev.create_bind_group(&wgpu::BindGroupDescriptor {
        label: None,
        layout: &bgl_rc,
        entries: &[
            wgpu::BindGroupEntry { binding: 0, resource: params_buf.as_entire_binding() },
            wgpu::BindGroupEntry { binding: 1, resource: image.as_entire_binding() },
            wgpu::BindGroupEntry { binding: 2, resource: blocks_buf.as_entire_binding() },
            wgpu::BindGroupEntry { binding: 3, resource: depth.as_entire_binding() },
            wgpu::BindGroupEntry { binding: 4, resource: fine_buf.as_ref().unwrap_or(&blocks_buf).as_entire_binding() },
        ],
    });
    // One dispatch per frame, or bands of rows with a progress line.
    let times = crate::gpu::timing::timed_banded_frames(
        gpu,
        &raycast,
        [&bg_s, &bg_rc],
        (&params_buf, params, |p: &mut RayParams, y0| p.image[3] = y0 as i32),
        (o.width, o.height, if o.progress { 32 } else { o.height }),
        ("raycast", "rendering rows", o.progress),
        o.frames.max(1),
    )?;
    let words: Vec<u32> = bytemuck::cast_slice(&gpu.read_buffer(&image)?).to_vec();
    let rgba = words.iter().flat_map(|w| w.to_le_bytes()).collect();
    let depth: Vec<f32> = bytemuck::cast_slice(&gpu.read_buffer(&depth)?).to_vec();
    let frame =
        Frame { width: o.width, height: o.height, rgba, ms_per_frame: times[times.len() / 2], empty_blocks: empty };
    Ok((frame, depth))
}

/// The same ray caster on the CPU with the exact evaluator in f64 (no
/// skipping: it must give the same image, which tests the skipping too).
pub fn cpu_render(d: &Derivation, vol: &LatticeVolume, o: &RenderOptions) -> Vec<u8> {
    cpu_render_with_depth(d, vol, o).0
}

/// [`cpu_render`], and the ray parameter t of every pixel's hit (-1 for a miss).
pub fn cpu_render_with_depth(d: &Derivation, vol: &LatticeVolume, o: &RenderOptions) -> (Vec<u8>, Vec<f32>) {
    let p = ray_params(d, vol, o);
    let plan = HitPlan::new(d);
    let data = |j: &[i64]| vol.get(j) as f64;
    let f = |x: DVec3| d.eval_f64(&x.to_array(), &data);
    let (w, h) = (o.width as usize, o.height as usize);
    let rows: Vec<usize> = (0..h).collect();
    let threads = std::thread::available_parallelism().map(|n| n.get()).unwrap_or(1);
    let chunks: Vec<Vec<usize>> = rows.chunks(h.div_ceil(threads)).map(|c| c.to_vec()).collect();
    let mut out = vec![0u8; w * h * 4];
    let mut depth = vec![-1f32; w * h];
    std::thread::scope(|s| {
        let handles: Vec<_> = chunks
            .iter()
            .map(|rows| {
                let (f, plan) = (&f, &plan);
                s.spawn(move || {
                    let mut part = Vec::new();
                    for &y in rows {
                        for x in 0..w {
                            let sx = (x as f64 + 0.5) / w as f64 * 2.0 - 1.0;
                            let sy = 1.0 - (y as f64 + 0.5) / h as f64 * 2.0;
                            let (eye, fw, rt, up) = (d3(p.eye), d3(p.forward), d3(p.right), d3(p.up));
                            let (origin, dir) = if o.perspective {
                                let dv = fw + sx * rt + sy * up;
                                (eye, dv / dv.length())
                            } else {
                                (eye + sx * rt + sy * up, fw)
                            };
                            let (c, t) = cast_ray(f, plan, origin, dir, &p, o);
                            part.push((y, x, c, t));
                        }
                    }
                    part
                })
            })
            .collect();
        for hnd in handles {
            for (y, x, c, t) in hnd.join().expect("cpu ray cast") {
                let i = (y * w + x) * 4;
                out[i..i + 4].copy_from_slice(&c);
                depth[y * w + x] = t.map_or(-1.0, |t| t as f32);
            }
        }
    });
    (out, depth)
}

/// The first hit by fixed steps and bisection (as the shader's step mode).
fn hit_step(
    f: &dyn Fn(DVec3) -> (f64, Vec<f64>),
    origin: DVec3,
    dir: DVec3,
    t0: f64,
    t1: f64,
    o: &RenderOptions,
) -> Option<f64> {
    let at = |t: f64| origin + t * dir;
    let iso = o.iso as f64;
    let step = o.step as f64;
    let mut t = t0;
    let mut prev = f(at(t)).0 - iso;
    let mut hit = None;
    while t < t1 {
        let tn = (t + step).min(t1);
        let v = f(at(tn)).0 - iso;
        if (prev < 0.0) != (v < 0.0) {
            hit = Some((t, tn));
            break;
        }
        prev = v;
        t = tn;
    }
    let (mut a, mut b) = hit?;
    let sa = f(at(a)).0 - iso < 0.0;
    while b - a >= 1e-4 {
        let m = 0.5 * (a + b);
        if (f(at(m)).0 - iso < 0.0) == sa {
            a = m;
        } else {
            b = m;
        }
    }
    Some(0.5 * (a + b))
}

/// The exact first hit: the ray from the box entry is cut at every plane
/// of the plan, each segment sampled as the plan says, its Bernstein
/// coefficients tested for one sign and otherwise searched with
/// [`first_root`] (the shader's exact walk in f64, without skipping). `f`
/// gives the value and gradient.
pub fn hit_exact(
    f: &dyn Fn(DVec3) -> (f64, Vec<f64>),
    plan: &HitPlan,
    origin: DVec3,
    dir: DVec3,
    t0: f64,
    t1: f64,
    iso: f64,
) -> Option<f64> {
    let o = origin + t0 * dir;
    let tend = t1 - t0;
    let fam: Vec<(f64, f64, f64)> = plan
        .families
        .iter()
        .map(|(n, off, g)| (DVec3::from_array(*n).dot(o) - off, DVec3::from_array(*n).dot(dir), *g))
        .collect();
    let steps: Vec<f64> =
        fam.iter().map(|&(_, b, g)| if b.abs() > 1e-9 { g / b.abs() } else { f64::INFINITY }).collect();
    let mut next: Vec<f64> = fam.iter().map(|&(a, b, g)| next_crossing(a, b, g, 0.0)).collect();
    let last = plan.samples.len() - 1;
    // Value and d/dt along the ray.
    let sample = |t: f64| {
        let (v, g) = f(o + t * dir);
        (v - iso, DVec3::from_slice(&g).dot(dir))
    };
    let carry = !plan.carried_to_bernstein.is_empty();
    let mut t = 0.0;
    // Value, d/dt and d²/dt² at the previous segment's end, and the sum of
    // 1 / len² over the carry chain (see HIT_CARRY_BOUND).
    let mut prev: Option<(f64, f64, f64, f64)> = None;
    let mut cond = Vec::with_capacity(plan.degree + 1);
    while t < tend {
        let te = next.iter().fold(tend, |m, &x| m.min(x));
        for (x, s) in next.iter_mut().zip(&steps) {
            if *x <= te + HIT_MERGE {
                *x += s;
            }
        }
        if te < tend && te - t < HIT_MERGE {
            continue;
        }
        let len = te - t;
        cond.clear();
        let start = match prev {
            Some((v, dt, _, _)) if plan.shared_ends => (v, dt),
            _ => sample(t),
        };
        let end = if plan.shared_ends { sample(te) } else { (0.0, 0.0) };
        let carried = match prev {
            Some((_, _, _, acc)) => carry && len * len * acc <= HIT_CARRY_BOUND,
            None => false,
        };
        let c = match prev {
            Some((_, _, s, _)) if carried => {
                cond.extend([start.0, len * start.1, len * len * s]);
                for &u in &plan.carried_samples {
                    let (v, dt) = sample(t + len * u);
                    cond.extend([v, len * dt]);
                }
                cond.extend([end.0, len * end.1]);
                plan.coefficients_with(&plan.carried_to_bernstein, &cond)
            }
            _ => {
                for (i, &(u, grad)) in plan.samples.iter().enumerate() {
                    let (v, dt) = match i {
                        0 if plan.shared_ends => start,
                        _ if plan.shared_ends && i == last => end,
                        _ => sample(t + len * u),
                    };
                    cond.push(v);
                    if grad {
                        cond.push(len * dt);
                    }
                }
                plan.coefficients(&cond)
            }
        };
        let lo = c.iter().fold(f64::INFINITY, |m, &x| m.min(x));
        let hi = c.iter().fold(f64::NEG_INFINITY, |m, &x| m.max(x));
        if lo < 0.0 && hi >= 0.0 {
            if let Some(u) = first_root(&c, HIT_TOLERANCE / len) {
                return Some(t0 + t + u * len);
            }
        }
        let s = if carry { end_second_derivative(&c, len) } else { 0.0 };
        let acc = match prev {
            Some((_, _, _, acc)) if carried => acc,
            _ => 0.0,
        } + 1.0 / (len * len);
        prev = Some((end.0, end.1, s, acc));
        t = te;
    }
    None
}

fn cast_ray(
    f: &dyn Fn(DVec3) -> (f64, Vec<f64>),
    plan: &HitPlan,
    origin: DVec3,
    dir: DVec3,
    p: &RayParams,
    o: &RenderOptions,
) -> ([u8; 4], Option<f64>) {
    let at = |t: f64| origin + t * dir;
    let (mut t0, mut t1) = (0f64, f64::INFINITY);
    for i in 0..3 {
        let a = (p.box_lo[i] as f64 - origin[i]) / dir[i];
        let b = (p.box_hi[i] as f64 - origin[i]) / dir[i];
        t0 = t0.max(a.min(b));
        t1 = t1.min(a.max(b));
    }
    let mut color = DVec3::new(0.08, 0.08, 0.1);
    let mut hit = None;
    if t0 < t1 {
        hit = match o.hit {
            HitMode::Step => hit_step(f, origin, dir, t0, t1, o),
            HitMode::Exact => hit_exact(f, plan, origin, dir, t0, t1, o.iso as f64),
        };
        if let Some(th) = hit {
            // Normalised by dividing by the length (not glam's normalize,
            // which multiplies by the reciprocal) to keep the rounding.
            let g = DVec3::from_slice(&f(at(th)).1);
            let mut n = g / g.length().max(1e-20);
            if n.dot(dir) > 0.0 {
                n = -n;
            }
            let up = d3(p.up);
            let ul = up.length().max(1e-20);
            let l = {
                let v = -dir + 0.35 * up / ul;
                v / v.length()
            };
            let hv = {
                let v = l - dir;
                v / v.length()
            };
            let diffuse = n.dot(l).max(0.0);
            let specular = n.dot(hv).max(0.0).powf(40.0);
            color = DVec3::new(0.85, 0.72, 0.55) * (0.15 + 0.75 * diffuse) + 0.3 * specular;
        }
    }
    let q = |v: f64| (v.clamp(0.0, 1.0) * 255.0 + 0.5) as u8;
    ([q(color[0]), q(color[1]), q(color[2]), 255], hit)
}

/// Writes RGBA8 pixels as a PNG.
/// Writes an RGBA PNG atomically (a temporary file renamed over `path`), so
/// an interrupted run leaves either the old image or the new one.
pub fn write_png(path: &std::path::Path, width: u32, height: u32, rgba: &[u8]) -> std::io::Result<()> {
    if let Some(dir) = path.parent().filter(|p| !p.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir)?;
    }
    let mut bytes = Vec::new();
    {
        let mut enc = png::Encoder::new(&mut bytes, width, height);
        enc.set_color(png::ColorType::Rgba);
        enc.set_depth(png::BitDepth::Eight);
        let mut w = enc.write_header().map_err(std::io::Error::other)?;
        w.write_image_data(rgba).map_err(std::io::Error::other)?;
    }
    boxforge::build::output::write_atomic(path, &bytes).map_err(|e| std::io::Error::other(e.to_string()))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn derive(name: &str) -> Derivation {
        Derivation::new(&boxforge::spec::catalog::get(name).unwrap()).unwrap()
    }

    #[test]
    fn conversions_reproduce_a_polynomial_from_its_conditions() {
        for name in ["bcc7", "cc_tricubic", "fcc6", "bcc_linear", "bcc8"] {
            let plan = HitPlan::new(&derive(name));
            let n = plan.degree;
            let b: Vec<f64> = (0..=n).map(|j| ((j * 7 + 3) % 5) as f64 - 2.0 + 0.1 * j as f64).collect();
            let h = 1e-5;
            let val = |u: f64| bernstein_at(&b, u);
            let du = |u: f64| (val(u + h) - val(u - h)) / (2.0 * h);
            let du2 = |u: f64| (val(u + h) - 2.0 * val(u) + val(u - h)) / (h * h);
            let mut cond = vec![];
            for &(u, grad) in &plan.samples {
                cond.push(val(u));
                if grad {
                    cond.push(du(u));
                }
            }
            let c = plan.coefficients(&cond);
            for (x, y) in c.iter().zip(&b) {
                assert!((x - y).abs() < 1e-6, "{name}: {c:?} vs {b:?}");
            }
            if !plan.carried_to_bernstein.is_empty() {
                let mut cond = vec![val(0.0), du(0.0), du2(0.0)];
                for &u in &plan.carried_samples {
                    cond.extend([val(u), du(u)]);
                }
                cond.extend([val(1.0), du(1.0)]);
                let c = plan.coefficients_with(&plan.carried_to_bernstein, &cond);
                for (x, y) in c.iter().zip(&b) {
                    assert!((x - y).abs() < 1e-3, "{name} carried: {c:?} vs {b:?}");
                }
                let s = end_second_derivative(&b, 2.0);
                assert!((s - du2(1.0) / 4.0).abs() < 1e-3, "{s} vs {}", du2(1.0) / 4.0);
            }
        }
    }

    #[test]
    fn first_root_finds_the_first_of_several_roots() {
        // (u - 0.3)(u - 0.35)(u - 0.8) in Bernstein form via samples.
        let p = |u: f64| (u - 0.3) * (u - 0.35) * (u - 0.8);
        let n = 3;
        let nodes: Vec<f64> = (0..=n).map(|i| i as f64 / n as f64).collect();
        let m: Vec<Vec<f64>> = nodes.iter().map(|&x| (0..=n).map(|j| bernstein(n, j, x)).collect()).collect();
        let inv = invert(&m);
        let v: Vec<f64> = nodes.iter().map(|&x| p(x)).collect();
        let c: Vec<f64> = inv.iter().map(|r| r.iter().zip(&v).map(|(a, b)| a * b).sum()).collect();
        let u = first_root(&c, 1e-9).unwrap();
        assert!((u - 0.3).abs() < 1e-8, "{u}");
        // Two close roots only: none when the polynomial stays positive.
        let q = |u: f64| (u - 0.5).powi(2) + 1e-3;
        let v: Vec<f64> = nodes.iter().map(|&x| q(x)).collect();
        let c: Vec<f64> = inv.iter().map(|r| r.iter().zip(&v).map(|(a, b)| a * b).sum()).collect();
        assert_eq!(first_root(&c, 1e-9), None);
    }

    #[test]
    fn carried_second_derivatives_give_the_hits_of_fresh_samples() {
        let d = derive("bcc7");
        let vol = LatticeVolume::marschner_lobb(&d.filter.lattice, [24; 3]).unwrap();
        let data = |j: &[i64]| vol.get(j) as f64;
        let f = |x: DVec3| d.eval_f64(&x.to_array(), &data);
        let plan = HitPlan::new(&d);
        assert!(!plan.carried_to_bernstein.is_empty());
        let fresh = HitPlan { carried_to_bernstein: vec![], ..plan.clone() };
        let mut hits = 0;
        for k in 0..40 {
            let a = 0.3 + 0.05 * k as f64;
            let dir = DVec3::new(a.cos() * 0.9, a.sin() * 0.9, -0.43).normalize();
            let origin = DVec3::new(11.5, 11.7, 11.3) - 9.0 * dir;
            let x = hit_exact(&f, &plan, origin, dir, 0.0, 18.0, 0.5);
            let y = hit_exact(&f, &fresh, origin, dir, 0.0, 18.0, 0.5);
            assert_eq!(x.is_some(), y.is_some(), "ray {k}: {x:?} vs {y:?}");
            if let (Some(x), Some(y)) = (x, y) {
                assert!((x - y).abs() < 1e-3, "ray {k}: {x} vs {y}");
                hits += 1;
            }
        }
        assert!(hits > 10, "{hits}");
    }
}
