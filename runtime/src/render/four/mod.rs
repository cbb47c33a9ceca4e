//! Isosurfaces of time-varying (4D) volumes at any time t, not only the
//! sampled ones: each ray marches through the valid box of the volume's
//! space and evaluates the 4D spline at (x, y, z, t) (the generated module's
//! `<f>_eval` on `vec4` points, samples in its storage buffer), refines the
//! crossing by bisection and shades with `<f>_eval_grad`'s spatial gradient.
//! [`cpu_reference`] runs the same march with the exact evaluator (f64),
//! the check of every image.
//!
//! [`FourIsoRenderer::render_dvr`] draws emission-absorption volume
//! renderings the same way ([`cpu_reference_dvr`] its reference).
//!
//! With [`FourIsoOptions::exact`] the isosurface is found by the exact
//! first-hit walk instead of fixed steps ([`hit`]): the ray is cut into the
//! segments where the 4D spline is one polynomial and the first root is
//! isolated on each ([`cpu_reference_exact`] its reference).
//!
//! Orthographic, no empty-space skipping (the 3D ray caster's min/max
//! blocks have no 4D counterpart yet).

pub mod hit;
pub use hit::cpu_reference_exact;

use crate::gpu::binding::storage_entry;
use crate::gpu::Gpu;
use crate::render::camera::{Camera, CameraUniform};
use crate::render::dvr::transfer::Tf1d;
use crate::render::RenderError;
use crate::volume::{DeviceVolume4, LatticeVolume4};
use boxforge::derive::Derivation;
use boxforge::emit::{emit, EmitOptions, Layout};

/// What a 4D isosurface frame shows.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FourIsoOptions {
    pub width: u32,
    pub height: u32,
    /// The iso-value.
    pub iso: f32,
    /// The march step in lattice units (a crossing inside one step whose
    /// ends have the same sign is missed; 0.25 resolves the test signal).
    pub step: f32,
    pub camera: Camera,
    /// The exact first hit (every piece of the spline along the ray
    /// searched for its first root) instead of fixed steps and bisection.
    pub exact: bool,
}

impl Default for FourIsoOptions {
    fn default() -> Self {
        FourIsoOptions { width: 256, height: 256, iso: 0.5, step: 0.25, camera: Camera::default(), exact: false }
    }
}

/// Bisection steps after a crossing is bracketed.
const BISECTIONS: u32 = 16;

#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct FourParams {
    camera: CameraUniform,
    /// t (lattice units), iso, step, unused.
    misc: [f32; 4],
    /// width, height, bisections, unused.
    size: [u32; 4],
    /// DVR: the transfer function's first and last value, its entries, unused.
    misc2: [f32; 4],
}

fn shader(name: &str) -> String {
    format!(
        "
struct FourParams {{
    eye: vec4<f32>, forward: vec4<f32>, right: vec4<f32>, up: vec4<f32>,
    box_lo: vec4<f32>, box_hi: vec4<f32>,
    misc: vec4<f32>,
    size: vec4<u32>,
    misc2: vec4<f32>,
}}
@group(1) @binding(0) var<storage, read> four_p: FourParams;
@group(1) @binding(1) var<storage, read_write> four_image: array<u32>;
// DVR: the transfer function table, (r, g, b, extinction per cell) over
// [misc2.x, misc2.y] in misc2.z entries.
@group(1) @binding(2) var<storage, read> four_tf: array<vec4<f32>>;

/// The ray of pixel `px` (orthographic) and where it crosses the valid box.
struct FourRay {{
    origin: vec3<f32>,
    dir: vec3<f32>,
    tmin: f32,
    tmax: f32,
}}

fn four_ray(px: vec2<u32>) -> FourRay {{
    let size = vec2<f32>(four_p.size.xy);
    let ndc = vec2<f32>((f32(px.x) + 0.5) / size.x * 2.0 - 1.0, 1.0 - (f32(px.y) + 0.5) / size.y * 2.0);
    let o = four_p.eye.xyz + four_p.right.xyz * ndc.x + four_p.up.xyz * ndc.y;
    let dir = four_p.forward.xyz;
    let inv = 1.0 / dir;
    let ta = (four_p.box_lo.xyz - o) * inv;
    let tb = (four_p.box_hi.xyz - o) * inv;
    let tmin = max(max(min(ta.x, tb.x), min(ta.y, tb.y)), min(ta.z, tb.z));
    let tmax = min(min(max(ta.x, tb.x), max(ta.y, tb.y)), max(ta.z, tb.z));
    return FourRay(o, dir, tmin, tmax);
}}

fn four_f(p: vec3<f32>) -> f32 {{
    return {name}_eval(vec4<f32>(p, four_p.misc.x)) - four_p.misc.y;
}}

/// The grey level of a surface point p seen along dir (headlight on the
/// spatial gradient), opaque RGBA8.
fn four_shade(p: vec3<f32>, dir: vec3<f32>) -> u32 {{
    let g = {name}_eval_grad(vec4<f32>(p, four_p.misc.x)).gradient.xyz;
    let len = length(g);
    let shade = select(0.15, 0.15 + 0.85 * abs(dot(g / len, dir)), len > 0.0);
    let v = u32(round(clamp(shade, 0.0, 1.0) * 255.0));
    return 0xff000000u | (v << 16u) | (v << 8u) | v;
}}

@compute @workgroup_size(8, 8)
fn four_iso_main(@builtin(global_invocation_id) gid: vec3<u32>) {{
    let w = four_p.size.x;
    if (gid.x >= w || gid.y >= four_p.size.y) {{
        return;
    }}
    let r = four_ray(gid.xy);
    let o = r.origin;
    let dir = r.dir;
    let tmin = r.tmin;
    let tmax = r.tmax;
    var color = 0xff000000u;
    let step = four_p.misc.z;
    var a = max(tmin, 0.0);
    if (tmax > a) {{
        var fa = four_f(o + dir * a);
        let n = u32(ceil((tmax - a) / step));
        for (var i = 0u; i < n; i++) {{
            let b = min(a + step, tmax);
            let fb = four_f(o + dir * b);
            if ((fa < 0.0) != (fb < 0.0)) {{
                var lo = a;
                var hi = b;
                var flo = fa;
                for (var k = 0u; k < four_p.size.z; k++) {{
                    let m = 0.5 * (lo + hi);
                    let fm = four_f(o + dir * m);
                    if ((fm < 0.0) == (flo < 0.0)) {{
                        lo = m;
                        flo = fm;
                    }} else {{
                        hi = m;
                    }}
                }}
                color = four_shade(o + dir * (0.5 * (lo + hi)), dir);
                break;
            }}
            a = b;
            fa = fb;
        }}
    }}
    four_image[gid.y * w + gid.x] = color;
}}

/// Emission-absorption along the ray at the midpoints of fixed steps, front
/// to back, until the opacity passes 0.99.
@compute @workgroup_size(8, 8)
fn four_dvr_main(@builtin(global_invocation_id) gid: vec3<u32>) {{
    let w = four_p.size.x;
    if (gid.x >= w || gid.y >= four_p.size.y) {{
        return;
    }}
    let r = four_ray(gid.xy);
    let o = r.origin;
    let dir = r.dir;
    let tmin = r.tmin;
    let tmax = r.tmax;
    let step = four_p.misc.z;
    let a = max(tmin, 0.0);
    var rgb = vec3<f32>(0.0);
    var alpha = 0.0;
    if (tmax > a) {{
        let n = u32(ceil((tmax - a) / step));
        let entries = four_p.misc2.z;
        for (var i = 0u; i < n; i++) {{
            let s = a + (f32(i) + 0.5) * step;
            if (s > tmax) {{
                break;
            }}
            let v = {name}_eval(vec4<f32>(o + dir * s, four_p.misc.x));
            let u = clamp((v - four_p.misc2.x) * ((entries - 1.0) / (four_p.misc2.y - four_p.misc2.x)), 0.0, entries - 1.0);
            let k = min(u32(floor(u)), u32(entries) - 2u);
            let e = mix(four_tf[k], four_tf[k + 1u], u - f32(k));
            let a_s = 1.0 - exp(-e.w * step);
            rgb += (1.0 - alpha) * a_s * e.xyz;
            alpha += (1.0 - alpha) * a_s;
            if (alpha > 0.99) {{
                break;
            }}
        }}
    }}
    let c = vec3<u32>(round(clamp(rgb, vec3<f32>(0.0), vec3<f32>(1.0)) * 255.0));
    four_image[gid.y * w + gid.x] = 0xff000000u | (c.z << 16u) | (c.y << 8u) | c.x;
}}
"
    )
}

/// The valid box of a 4D volume's space: the points whose spatial support
/// lies inside the samples (lattice coordinates).
pub fn valid_box(d: &Derivation, vol: &LatticeVolume4) -> ([f32; 3], [f32; 3]) {
    let r = crate::volume::support_radius(d) as f32;
    let lo = [r; 3];
    let hi = std::array::from_fn(|a| (vol.dims[a] as f32 - 1.0 - r).max(r));
    (lo, hi)
}

/// A compiled 4D isosurface renderer over one 4D volume.
pub struct FourIsoRenderer<'a> {
    gpu: &'a Gpu,
    pipeline: wgpu::ComputePipeline,
    dvr_pipeline: wgpu::ComputePipeline,
    bgl1: wgpu::BindGroupLayout,
    bg0: wgpu::BindGroup,
    lo: [f32; 3],
    hi: [f32; 3],
    /// The module and caster, and the exact walk's plan: the exact-hit
    /// pipeline is compiled on the first frame that asks for it.
    source: String,
    plan: Option<crate::render::iso::TimeHitPlan>,
    file_name: String,
    name: String,
    exact_pipeline: std::cell::OnceCell<wgpu::ComputePipeline>,
    bgl0: wgpu::BindGroupLayout,
}

impl<'a> FourIsoRenderer<'a> {
    /// Emits `d` (4D) for `layout`, uploads `vol` and compiles the caster.
    ///
    /// # Errors
    ///
    /// The generator's refusal, a volume the device cannot hold, device errors.
    pub fn new(gpu: &'a Gpu, d: &Derivation, vol: &LatticeVolume4, layout: Layout) -> Result<Self, RenderError> {
        let module =
            emit(d, &EmitOptions { layout, kernels: false, command: "boxforge render".into(), ..Default::default() })?;
        let dv = DeviceVolume4::new(gpu, vol, layout)?;
        let source = format!("{}\n{}", module.source, shader(&d.filter.name));
        let sm = gpu.compile(&module.file_name, &source)?;
        let dev = &gpu.device;
        let (bgl0, bg0) = dv.group(gpu)?;
        let bgl1 = dev.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("4d iso"),
            entries: &[storage_entry(0, true), storage_entry(1, false), storage_entry(2, true)],
        });
        let pipeline = gpu.pipeline("four_iso_main", &sm, &[&bgl0, &bgl1], "four_iso_main")?;
        let dvr_pipeline = gpu.pipeline("four_dvr_main", &sm, &[&bgl0, &bgl1], "four_dvr_main")?;
        let (lo, hi) = valid_box(d, vol);
        Ok(FourIsoRenderer {
            gpu,
            pipeline,
            dvr_pipeline,
            bgl1,
            bg0,
            lo,
            hi,
            source,
            plan: crate::render::iso::TimeHitPlan::new(d),
            file_name: module.file_name,
            name: d.filter.name.clone(),
            exact_pipeline: std::cell::OnceCell::new(),
            bgl0,
        })
    }

    /// The frame at time `t` (lattice units of the time axis: frame k at
    /// t = k), RGBA8, row-major from the top.
    pub fn render(&self, t: f32, o: &FourIsoOptions) -> Result<Vec<u8>, RenderError> {
        self.frame(t, o, None)
    }

    /// The direct volume rendering at time `t` through `tf` (emission and
    /// absorption at the midpoints of `o.step`; `o.iso` unused), RGBA8.
    pub fn render_dvr(&self, t: f32, o: &FourIsoOptions, tf: &Tf1d) -> Result<Vec<u8>, RenderError> {
        self.frame(t, o, Some(tf))
    }

    fn frame(&self, t: f32, o: &FourIsoOptions, tf: Option<&Tf1d>) -> Result<Vec<u8>, RenderError> {
        if o.width == 0 || o.height == 0 {
            return Err(RenderError::EmptyTarget);
        }
        let (gpu, dev) = (self.gpu, &self.gpu.device);
        let params = FourParams {
            camera: CameraUniform::orbit(&o.camera, self.lo, self.hi, o.width, o.height),
            misc: [t, o.iso, o.step, 0.0],
            size: [o.width, o.height, BISECTIONS, 0],
            misc2: tf.map_or([0.0, 1.0, 2.0, 0.0], |tf| [tf.lo, tf.hi, tf.entries.len() as f32, 0.0]),
        };
        let table: Vec<[f32; 4]> = tf.map_or(vec![[0.0; 4]; 2], |tf| tf.entries.clone());
        let tbuf = gpu.storage_buffer("4d transfer function", bytemuck::cast_slice(&table), false);
        let pbuf = gpu.storage_buffer("4d iso params", bytemuck::bytes_of(&params), false);
        let n = o.width as usize * o.height as usize;
        let img = gpu.storage_buffer("4d iso image", &vec![0u8; n * 4], true);
        let bg1 = gpu.checked("bind the 4D frame", || {
            dev.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("4d iso"),
                layout: &self.bgl1,
                entries: &[
                    wgpu::BindGroupEntry { binding: 0, resource: pbuf.as_entire_binding() },
                    wgpu::BindGroupEntry { binding: 1, resource: img.as_entire_binding() },
                    wgpu::BindGroupEntry { binding: 2, resource: tbuf.as_entire_binding() },
                ],
            })
        })?;
        let pipeline = match tf {
            Some(_) => &self.dvr_pipeline,
            None if o.exact => self.exact_pipeline()?,
            None => &self.pipeline,
        };
        gpu.dispatch("4d frame", pipeline, &[&self.bg0, &bg1], (o.width.div_ceil(8), o.height.div_ceil(8), 1))?;
        Ok(gpu.read_buffer(&img)?)
    }
}

impl FourIsoRenderer<'_> {
    /// The exact-hit pipeline, compiled once.
    fn exact_pipeline(&self) -> Result<&wgpu::ComputePipeline, RenderError> {
        if let Some(p) = self.exact_pipeline.get() {
            return Ok(p);
        }
        let plan = self.plan.as_ref().ok_or(RenderError::NotFourD)?;
        let source = format!("{}\n{}", self.source, hit::exact_shader(&self.name, plan));
        let sm = self.gpu.compile(&self.file_name, &source)?;
        let p = self.gpu.pipeline("four_exact_main", &sm, &[&self.bgl0, &self.bgl1], "four_exact_main")?;
        Ok(self.exact_pipeline.get_or_init(|| p))
    }
}

/// A frame drawn on the CPU, every pixel on every core: `shade` gets the
/// pixel's ray (origin, unit direction) and where it crosses the valid box
/// ([tmin, tmax], tmin clamped to 0), as the device's `four_ray` computes them.
fn cpu_frame(
    d: &Derivation,
    vol: &LatticeVolume4,
    o: &FourIsoOptions,
    shade: impl Fn([f64; 3], [f64; 3], f64, f64) -> [u8; 4] + Sync,
) -> Vec<u8> {
    let (lo, hi) = valid_box(d, vol);
    let cam = CameraUniform::orbit(&o.camera, lo, hi, o.width, o.height);
    let v3 = |a: [f32; 4]| [a[0] as f64, a[1] as f64, a[2] as f64];
    let (eye, fwd, right, up) = (v3(cam.eye), v3(cam.forward), v3(cam.right), v3(cam.up));
    let (blo, bhi) = (lo.map(f64::from), hi.map(f64::from));
    let (w, h) = (o.width as usize, o.height as usize);
    let pixels: Vec<usize> = (0..w * h).collect();
    let rgba = crate::par::par_map(&pixels, |&i| {
        let (px, py) = (i % w, i / w);
        let ndc = [(px as f64 + 0.5) / w as f64 * 2.0 - 1.0, 1.0 - (py as f64 + 0.5) / h as f64 * 2.0];
        let org: [f64; 3] = std::array::from_fn(|a| eye[a] + right[a] * ndc[0] + up[a] * ndc[1]);
        let (mut tmin, mut tmax) = (f64::NEG_INFINITY, f64::INFINITY);
        for a in 0..3 {
            let (ta, tb) = ((blo[a] - org[a]) / fwd[a], (bhi[a] - org[a]) / fwd[a]);
            tmin = tmin.max(ta.min(tb));
            tmax = tmax.min(ta.max(tb));
        }
        shade(org, fwd, tmin.max(0.0), tmax)
    });
    rgba.concat()
}

/// The same frame from the exact evaluator (f64), on all cores: the
/// reference every device frame is held to.
pub fn cpu_reference(d: &Derivation, vol: &LatticeVolume4, t: f64, o: &FourIsoOptions) -> Vec<u8> {
    let data = |j: &[i64]| vol.get(j) as f64;
    let _ = d.f64_tables();
    let (iso, step) = (o.iso as f64, o.step as f64);
    cpu_frame(d, vol, o, |org, fwd, start, tmax| {
        let at = |s: f64| -> [f64; 4] { [org[0] + fwd[0] * s, org[1] + fwd[1] * s, org[2] + fwd[2] * s, t] };
        let f = |s: f64| d.eval_f64(&at(s), &data).0 - iso;
        let mut a = start;
        if tmax <= a {
            return [0, 0, 0, 255];
        }
        let mut fa = f(a);
        let n = ((tmax - a) / step).ceil() as usize;
        for _ in 0..n {
            let b = (a + step).min(tmax);
            let fb = f(b);
            if (fa < 0.0) != (fb < 0.0) {
                let (mut l, mut r, mut fl) = (a, b, fa);
                for _ in 0..BISECTIONS {
                    let m = 0.5 * (l + r);
                    let fm = f(m);
                    if (fm < 0.0) == (fl < 0.0) {
                        (l, fl) = (m, fm);
                    } else {
                        r = m;
                    }
                }
                return shade(&d.eval_f64(&at(0.5 * (l + r)), &data).1, fwd);
            }
            (a, fa) = (b, fb);
        }
        [0, 0, 0, 255]
    })
}

/// `four_shade` on the CPU: the grey level of a surface point with
/// gradient `g` (its spatial part) seen along `fwd`.
fn shade(g: &[f64], fwd: [f64; 3]) -> [u8; 4] {
    let len = (g[0] * g[0] + g[1] * g[1] + g[2] * g[2]).sqrt();
    let s = if len > 0.0 { 0.15 + 0.85 * ((g[0] * fwd[0] + g[1] * fwd[1] + g[2] * fwd[2]) / len).abs() } else { 0.15 };
    let v = (s.clamp(0.0, 1.0) * 255.0).round() as u8;
    [v, v, v, 255]
}

/// [`FourIsoRenderer::render_dvr`]'s frame from the exact evaluator (f64),
/// the same steps, lookup and early stop: the reference of every DVR frame.
pub fn cpu_reference_dvr(d: &Derivation, vol: &LatticeVolume4, t: f64, o: &FourIsoOptions, tf: &Tf1d) -> Vec<u8> {
    let data = |j: &[i64]| vol.get(j) as f64;
    let _ = d.f64_tables();
    let step = o.step as f64;
    cpu_frame(d, vol, o, |org, fwd, a, tmax| {
        let (mut rgb, mut alpha) = ([0.0f64; 3], 0.0f64);
        if tmax > a {
            let n = ((tmax - a) / step).ceil() as usize;
            for i in 0..n {
                let s = a + (i as f64 + 0.5) * step;
                if s > tmax {
                    break;
                }
                let p = [org[0] + fwd[0] * s, org[1] + fwd[1] * s, org[2] + fwd[2] * s, t];
                let e = tf.at(d.eval_f64(&p, &data).0);
                let a_s = 1.0 - (-e[3] * step).exp();
                for c in 0..3 {
                    rgb[c] += (1.0 - alpha) * a_s * e[c];
                }
                alpha += (1.0 - alpha) * a_s;
                if alpha > 0.99 {
                    break;
                }
            }
        }
        let c = rgb.map(|x| (x.clamp(0.0, 1.0) * 255.0).round() as u8);
        [c[0], c[1], c[2], 255]
    })
}

/// The RMS over every pixel and channel (r, g, b in [0, 1]) of two RGBA8 frames.
pub fn rms_rgb(a: &[u8], b: &[u8]) -> f64 {
    let (mut sum, mut n) = (0.0, 0usize);
    for (p, q) in a.chunks(4).zip(b.chunks(4)) {
        for c in 0..3 {
            sum += ((p[c] as f64 - q[c] as f64) / 255.0).powi(2);
            n += 1;
        }
    }
    (sum / n.max(1) as f64).sqrt()
}

/// How two frames differ: the RMS of the grey levels (in [0, 1]) over the
/// pixels both hit, the pixels exactly one of them hits, and the RMS over
/// every pixel (a miss is black).
pub fn compare(a: &[u8], b: &[u8]) -> (f64, usize, f64) {
    let (mut sum, mut all, mut both, mut one) = (0.0, 0.0, 0usize, 0usize);
    for (p, q) in a.chunks(4).zip(b.chunks(4)) {
        let d2 = ((p[0] as f64 - q[0] as f64) / 255.0).powi(2);
        all += d2;
        match (p[0] > 0, q[0] > 0) {
            (true, true) => {
                both += 1;
                sum += d2;
            }
            (false, false) => {}
            _ => one += 1,
        }
    }
    let n = (a.len() / 4).max(1) as f64;
    ((sum / both.max(1) as f64).sqrt(), one, (all / n).sqrt())
}
