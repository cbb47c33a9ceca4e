//! Direct volume rendering (`render --mode dvr`): the emitted filter module
//! plus `templates/dvr.wgsl.j2`, a 1D transfer function ([`crate::render::dvr::transfer`])
//! with optional pre-integration, gradient shading from `<f>_eval_grad`,
//! early ray termination and empty-space skipping that knows the transfer
//! function; and a CPU reference ([`cpu_render`]) in f64 with the exact
//! evaluator that the GPU image must match.
//!
//! The model (both renderers): emission-absorption composited front to back
//! over segments of `step` cells from the ray's entry into the valid box
//! (segment k spans t0 + k step .. t0 + (k + 1) step; a partial last segment
//! is dropped). A segment's value and gradient are taken at its back end.
//! Without pre-integration its colour and opacity are the 1D table's at the
//! back value with opacity correction alpha = 1 - exp(-tau step) =
//! 1 - (1 - opacity)^(step / REF_STEP); with pre-integration they are the
//! table's entry for (front value, back value) (bilinear) and the normal
//! comes from the mean of the front and back gradients (the midpoint's to
//! second order: the back one alone shows the slabs again). Shading
//! multiplies the premultiplied colour by ambient + diffuse |n.l| and adds
//! alpha x specular |n.h|^20 (two-sided, the iso renderer's light), mixed
//! with the unshaded colour by the weight |g|^2 / (|g|^2 + g0^2), g0 = 2% of
//! the transfer function's range per cell, so flat regions (noisy normals)
//! stay unshaded. Rays stop once their opacity reaches
//! [`DvrOptions::termination`]; the rest shows the iso renderer's background.
//!
//! Skipping: the emitted `<f>_minmax_main` kernel bounds the spline on each
//! block of B^3 cubes; a block is flagged empty when the transfer function is
//! transparent over its [min, max] ([`Tf1d::transparent`]), and skipped
//! when it and its neighbours within ceil(step / B) blocks are empty
//! ([`skip_flags`]). A ray whose segment starts in a skipped block jumps over
//! every segment starting in that block (they end in empty blocks), so the
//! segment grid, and the image, are those of the unskipped ray.

pub mod transfer;

use crate::gpu::binding::{storage_entry, uniform_entry};
use crate::gpu::{Gpu, GpuError};
use crate::render::blocks::block_bounds;
use crate::render::dvr::transfer::{Preint, Tf1d, TransferFunction};
use crate::render::iso::{ray_params, Frame, RenderOptions};
use crate::volume::DeviceVolume;
use crate::volume::LatticeVolume;
use boxforge::derive::Derivation;
use boxforge::emit::{emit, EmitOptions, Layout};
use glam::{DVec3, Vec3};

/// Ambient, diffuse and specular weights of the shading.
pub const LIGHT: [f32; 3] = [0.35, 0.65, 0.25];
/// The shading weight's gradient scale, as a fraction of the TF range per cell.
pub const G0_OF_RANGE: f32 = 0.02;
/// Background colour (the iso renderer's).
pub const BACKGROUND: [f64; 3] = [0.08, 0.08, 0.1];

/// Options of one DVR image.
#[derive(Clone, Debug)]
pub struct DvrOptions {
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
    /// View azimuth and elevation in degrees.
    pub azimuth: f32,
    /// See `azimuth`.
    pub elevation: f32,
    /// Perspective (else orthographic) projection, as the iso renderer's.
    pub perspective: bool,
    /// TF-aware empty-space skipping.
    pub skip: bool,
    /// Pre-integrated segments (else point samples with opacity correction).
    pub preintegrate: bool,
    /// Segment length in cells.
    pub step: f32,
    /// Block edge of the skipping grid, in unit cubes.
    pub block: i32,
    /// Early ray termination: stop at this accumulated opacity.
    pub termination: f32,
    /// Frames to time after one warm-up frame.
    pub frames: usize,
    /// Render in bands of rows with a progress bar on stderr.
    pub progress: bool,
}

impl Default for DvrOptions {
    fn default() -> Self {
        DvrOptions {
            width: 256,
            height: 256,
            azimuth: 30.0,
            elevation: 25.0,
            perspective: false,
            skip: true,
            preintegrate: true,
            step: 0.5,
            block: 4,
            termination: 0.99,
            frames: 3,
            progress: false,
        }
    }
}

impl DvrOptions {
    /// The iso renderer's options with the same camera (for [`ray_params`]).
    fn camera(&self) -> RenderOptions {
        RenderOptions {
            width: self.width,
            height: self.height,
            azimuth: self.azimuth,
            elevation: self.elevation,
            perspective: self.perspective,
            step: self.step,
            block: self.block,
            skip: self.skip,
            ..RenderOptions::default()
        }
    }
}

/// The uniform block of `templates/dvr.wgsl.j2` (`<f>_DvrParams`).
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
pub struct DvrParams {
    /// Camera, as [`crate::render::iso::RayParams`]: eye position.
    pub eye: [f32; 4],
    /// View direction.
    pub forward: [f32; 4],
    /// Half the image's width along the view plane.
    pub right: [f32; 4],
    /// Half the image's height along the view plane.
    pub up: [f32; 4],
    /// Valid box (the filter's support inside the volume): low corner.
    pub box_lo: [f32; 4],
    /// Valid box: high corner.
    pub box_hi: [f32; 4],
    /// Table lo, (n_tf - 1) / (hi - lo), (n_pi - 1) / (hi - lo), step.
    pub tf: [f32; 4],
    /// Perspective, skip, pre-integrated (0/1), termination opacity.
    pub mode: [f32; 4],
    /// Ambient, diffuse, specular, g0.
    pub light: [f32; 4],
    /// Width, height, block edge, first row of the dispatch.
    pub image: [i32; 4],
    /// Blocks per axis, 1D table entries.
    pub blocks: [i32; 4],
    /// Pre-integration entries per axis.
    pub sizes: [i32; 4],
}

/// The uniform values of a DVR image.
pub fn dvr_params(d: &Derivation, vol: &LatticeVolume, table: &Tf1d, pi_size: usize, o: &DvrOptions) -> DvrParams {
    let r = ray_params(d, vol, &o.camera());
    let span = table.hi - table.lo;
    DvrParams {
        eye: r.eye,
        forward: r.forward,
        right: r.right,
        up: r.up,
        box_lo: r.box_lo,
        box_hi: r.box_hi,
        tf: [table.lo, (table.entries.len() as f32 - 1.0) / span, (pi_size as f32 - 1.0) / span, o.step],
        mode: [o.perspective as i32 as f32, o.skip as i32 as f32, o.preintegrate as i32 as f32, o.termination],
        light: [LIGHT[0], LIGHT[1], LIGHT[2], G0_OF_RANGE * span],
        image: [o.width as i32, o.height as i32, o.block, 0],
        blocks: [r.blocks[0], r.blocks[1], r.blocks[2], table.entries.len() as i32],
        sizes: [pi_size as i32, 0, 0, 0],
    }
}

/// The DVR template for filter `name`; `perm` makes the ray caster look
/// values up in the PERM cache (`<f>_perm_sample`, [`crate::render::perm`]) instead
/// of calling `<f>_eval_grad` (the only difference in the text).
pub(crate) fn dvr_template(name: &str, perm: bool) -> String {
    let mut env = minijinja::Environment::new();
    env.add_template("dvr", include_str!("../../../../templates/dvr.wgsl.j2")).expect("template");
    env.get_template("dvr").unwrap().render(minijinja::context! { name => name, perm => perm }).expect("render")
}

/// The emitted module with the DVR template appended.
pub fn shader_source(d: &Derivation, layout: Layout) -> Result<String, GpuError> {
    shader_source_with(d, layout, false)
}

/// [`shader_source`], with `perm` the ray caster reading the PERM cache.
pub(crate) fn shader_source_with(d: &Derivation, layout: Layout, perm: bool) -> Result<String, GpuError> {
    Ok(format!("{}\n{}", filter_module(d, layout)?, dvr_template(&d.filter.name, perm)))
}

/// The emitted filter module (fetch, eval, eval_grad, min/max kernel).
pub(crate) fn filter_module(d: &Derivation, layout: Layout) -> Result<String, GpuError> {
    let module = emit(d, &EmitOptions { layout, command: "boxforge render --mode dvr".into(), ..Default::default() })
        .map_err(|e| GpuError::Runtime(e.to_string()))?;
    Ok(module.source)
}

/// Per-block flags (1 = every value in the block maps to zero opacity) from
/// the [min, max] bounds of each block.
pub fn empty_flags(bounds: &[[f32; 2]], table: &Tf1d) -> Vec<u32> {
    bounds.iter().map(|b| table.transparent(b[0] as f64, b[1] as f64) as u32).collect()
}

/// The skipping flags: a block is skipped when it and every block within
/// `radius` blocks (Chebyshev distance, clamped at the grid's faces) are
/// empty; `blocks` is the grid's size, x fastest. With radius
/// ceil(step / block edge), a segment that starts in a skipped block ends in
/// empty blocks, so the shader skips every segment starting there.
pub fn skip_flags(empty: &[u32], blocks: [i32; 3], radius: i32) -> Vec<u32> {
    let [nx, ny, nz] = blocks.map(|n| n as usize);
    assert_eq!(empty.len(), nx * ny * nz, "one flag per block");
    let mut f = empty.to_vec();
    let r = radius.max(0) as usize;
    // A separable min filter, one axis at a time.
    for (n, stride) in [(nx, 1), (ny, nx), (nz, nx * ny)] {
        let prev = f.clone();
        for (i, out) in f.iter_mut().enumerate() {
            let c = (i / stride) % n;
            let (lo, hi) = (c.saturating_sub(r), (c + r).min(n - 1));
            *out = (lo..=hi).all(|q| prev[i - c * stride + q * stride] != 0) as u32;
        }
    }
    f
}

/// A volume ready for DVR on the device: the compiled pipeline, the samples
/// and the block [min, max] grid (computed once; each [`DvrScene::render`]
/// takes a transfer function and options).
pub struct DvrScene<'a> {
    pub(crate) gpu: &'a Gpu,
    pub(crate) d: &'a Derivation,
    pub(crate) vol: &'a LatticeVolume,
    block: i32,
    pipeline: wgpu::ComputePipeline,
    bgl_rc: wgpu::BindGroupLayout,
    pub(crate) bgl_s: wgpu::BindGroupLayout,
    pub(crate) bg_s: wgpu::BindGroup,
    pub(crate) dv: DeviceVolume,
    /// [min, max] of the spline over each block (x fastest).
    pub bounds: Vec<[f32; 2]>,
}

impl<'a> DvrScene<'a> {
    /// Compiles the shader, uploads the samples and bounds every block of
    /// `block`^3 cubes with the emitted min/max kernel.
    pub fn new(
        gpu: &'a Gpu,
        d: &'a Derivation,
        vol: &'a LatticeVolume,
        layout: Layout,
        block: i32,
    ) -> Result<DvrScene<'a>, GpuError> {
        let name = &d.filter.name;
        let source = shader_source(d, layout)?;
        Self::with_source(gpu, d, vol, layout, block, Custom { name, source: &source, minmax: name, reach: 0 })
    }

    /// A scene whose ray caster evaluates a function other than `d`'s
    /// emitted one (the hand-written schemes of [`crate::render::schemes`]): its
    /// module `source` (with `d`'s emitted module inside) defines
    /// `<name>_eval_grad` and the DVR template for `name`; blocks are
    /// bounded by `d`'s min/max kernel `<minmax>_minmax_main`, per cell and
    /// widened by `reach` cells when the function reaches further than
    /// `d`'s support ([`widen_bounds`]).
    pub(crate) fn with_source(
        gpu: &'a Gpu,
        d: &'a Derivation,
        vol: &'a LatticeVolume,
        layout: Layout,
        block: i32,
        custom: Custom<'_>,
    ) -> Result<DvrScene<'a>, GpuError> {
        let name = custom.name;
        let shader = gpu.compile(&format!("{name}.dvr.wgsl"), custom.source)?;
        let dev = &gpu.device;
        let dv = DeviceVolume::new(gpu, vol, layout)?;
        let bounds = if custom.reach > 0 {
            let cells = block_bounds(gpu, &shader, custom.minmax, &dv, vol.dims, 1)?;
            widen_bounds(&cells, vol.dims, block as usize, custom.reach)
        } else {
            block_bounds(gpu, &shader, custom.minmax, &dv, vol.dims, block)?
        };

        let bgl_s = dev.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("samples"),
            entries: &dv.layout_entries(0, wgpu::ShaderStages::COMPUTE),
        });
        let bgl_rc = dev.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("dvr"),
            entries: &caster_entries(),
        });
        let pipeline = gpu.pipeline("dvr", &shader, &[&bgl_s, &bgl_rc], &format!("{name}_dvr_main"))?;
        let bg_s = dev.create_bind_group(&wgpu::BindGroupDescriptor {
            label: None,
            layout: &bgl_s,
            entries: &dv.bind_entries(0),
        });
        Ok(DvrScene { gpu, d, vol, block, pipeline, bgl_rc, bgl_s, bg_s, dv, bounds })
    }

    /// Renders one image (a warm-up frame, then `o.frames` timed frames);
    /// `empty_blocks` is the fraction of blocks the transfer function leaves
    /// transparent (fewer are skipped: see [`skip_flags`]).
    pub fn render(&self, tf: &TransferFunction, o: &DvrOptions) -> Result<Frame, GpuError> {
        let table = tf.table();
        let pi = if o.preintegrate { Some(table.preintegrate(o.step as f64)) } else { None };
        self.render_tables(&table, pi.as_ref(), o)
    }

    /// [`DvrScene::render`] with tables already built (the pre-integration
    /// table must be for `o.step`; None renders without pre-integration).
    pub fn render_tables(&self, table: &Tf1d, pi: Option<&Preint>, o: &DvrOptions) -> Result<Frame, GpuError> {
        self.render_with(table, pi, o, None)
    }

    /// [`DvrScene::render_tables`] with the scene's ray caster, or another
    /// one (the PERM cache's, [`crate::render::perm`]).
    pub(crate) fn render_with(
        &self,
        table: &Tf1d,
        pi: Option<&Preint>,
        o: &DvrOptions,
        caster: Option<Caster<'_>>,
    ) -> Result<Frame, GpuError> {
        let (gpu, dev) = (self.gpu, &self.gpu.device);
        if o.block != self.block {
            return Err(GpuError::Runtime(format!(
                "the scene's block grid has edge {}, the options ask for {}",
                self.block, o.block
            )));
        }
        if let Some(p) = pi.filter(|p| p.step != o.step) {
            return Err(GpuError::Runtime(format!(
                "the pre-integration table is for step {}, the options ask for step {}",
                p.step, o.step
            )));
        }
        let o = &DvrOptions { preintegrate: pi.is_some(), ..o.clone() };
        let pi_size = pi.map_or(2, |p| p.size);
        let params = dvr_params(self.d, self.vol, table, pi_size, o);
        let empty_blocks = empty_flags(&self.bounds, table);
        let empty = empty_blocks.iter().filter(|&&f| f != 0).count() as f64 / empty_blocks.len().max(1) as f64;
        let radius = (o.step / self.block as f32).ceil() as i32;
        let flags = skip_flags(&empty_blocks, [params.blocks[0], params.blocks[1], params.blocks[2]], radius);
        let pi_entries: Vec<[f32; 4]> = pi.map_or_else(|| vec![[0.0; 4]; 4], |p| p.entries.clone());
        let pixels = (o.width * o.height) as usize;
        let params_buf = gpu.uniform_buffer("dvr params", bytemuck::bytes_of(&params));
        let image = gpu.storage_buffer("dvr image", &vec![0u8; pixels * 4], true);
        let flags_buf = gpu.storage_buffer("dvr flags", bytemuck::cast_slice(&flags), false);
        let tf_buf = gpu.storage_buffer("dvr tf", bytemuck::cast_slice(&table.entries), false);
        let pi_buf = gpu.storage_buffer("dvr preint", bytemuck::cast_slice(&pi_entries), false);
        let mut entries = vec![
            wgpu::BindGroupEntry { binding: 0, resource: params_buf.as_entire_binding() },
            wgpu::BindGroupEntry { binding: 1, resource: image.as_entire_binding() },
            wgpu::BindGroupEntry { binding: 2, resource: flags_buf.as_entire_binding() },
            wgpu::BindGroupEntry { binding: 3, resource: tf_buf.as_entire_binding() },
            wgpu::BindGroupEntry { binding: 4, resource: pi_buf.as_entire_binding() },
        ];
        let (pipeline, layout) = match caster {
            Some(c) => {
                entries.extend(c.extra);
                (c.pipeline, c.bgl)
            }
            None => (&self.pipeline, &self.bgl_rc),
        };
        let bg_rc = dev.create_bind_group(&wgpu::BindGroupDescriptor { label: None, layout, entries: &entries });
        let times = crate::gpu::timing::timed_banded_frames(
            gpu,
            pipeline,
            [&self.bg_s, &bg_rc],
            (&params_buf, params, |p: &mut DvrParams, y0| p.image[3] = y0 as i32),
            (o.width, o.height, if o.progress { 16 } else { o.height }),
            ("dvr", "volume rendering rows", o.progress),
            o.frames,
        )?;
        let words: Vec<u32> = bytemuck::cast_slice(&gpu.read_buffer(&image)?).to_vec();
        let rgba = words.iter().flat_map(|w| w.to_le_bytes()).collect();
        let ms = if times.is_empty() { f64::NAN } else { times[times.len() / 2] };
        Ok(Frame { width: o.width, height: o.height, rgba, ms_per_frame: ms, empty_blocks: empty })
    }
}

/// The group-1 layout entries of the ray caster (bindings 0 to 4).
pub(crate) fn caster_entries() -> Vec<wgpu::BindGroupLayoutEntry> {
    vec![
        uniform_entry(0),
        storage_entry(1, false),
        storage_entry(2, true),
        storage_entry(3, true),
        storage_entry(4, true),
    ]
}

/// A ray caster other than the scene's own: its pipeline, its group-1
/// layout and the group-1 entries it adds after binding 4.
pub(crate) struct Caster<'b> {
    pub pipeline: &'b wgpu::ComputePipeline,
    pub bgl: &'b wgpu::BindGroupLayout,
    pub extra: Vec<wgpu::BindGroupEntry<'b>>,
}

/// The ray-cast function of [`DvrScene::with_source`].
pub(crate) struct Custom<'s> {
    /// Prefix of `<name>_eval_grad` and of the DVR template's names.
    pub name: &'s str,
    /// The whole module: evaluation, min/max kernel and DVR template.
    pub source: &'s str,
    /// Prefix of the min/max kernel that bounds the blocks.
    pub minmax: &'s str,
    /// Cells beyond a block whose values the function reaches (0: the
    /// blocks are bounded directly by the min/max kernel).
    pub reach: usize,
}

/// Block bounds from cell bounds (`cells`, one per unit cube of `dims`, x
/// fastest): each block of `block`^3 cells gets the union over its cells
/// and every cell within `reach` of it, the bound of a function whose value
/// at a point is a convex combination of values within `reach` cells of it.
pub fn widen_bounds(cells: &[[f32; 2]], dims: [usize; 3], block: usize, reach: usize) -> Vec<[f32; 2]> {
    let blocks = dims.map(|n| n.div_ceil(block));
    // Separable: widen along x, then y, then z, over the window of each block.
    let window = |b: usize, n: usize| (b * block).saturating_sub(reach)..((b + 1) * block + reach).min(n);
    let mut cur = cells.to_vec();
    let mut shape = dims;
    for axis in 0..3 {
        let mut next_shape = shape;
        next_shape[axis] = blocks[axis];
        let stride = |s: [usize; 3]| [1, s[0], s[0] * s[1]];
        let (si, so) = (stride(shape), stride(next_shape));
        let mut next = vec![[f32::INFINITY, f32::NEG_INFINITY]; next_shape.iter().product()];
        for z in 0..next_shape[2] {
            for y in 0..next_shape[1] {
                for x in 0..next_shape[0] {
                    let o = [x, y, z];
                    let mut b = [f32::INFINITY, f32::NEG_INFINITY];
                    for c in window(o[axis], dims[axis]) {
                        let mut i = o;
                        i[axis] = c;
                        let v = cur[i[0] * si[0] + i[1] * si[1] + i[2] * si[2]];
                        b = [b[0].min(v[0]), b[1].max(v[1])];
                    }
                    next[x * so[0] + y * so[1] + z * so[2]] = b;
                }
            }
        }
        cur = next;
        shape = next_shape;
    }
    cur
}

/// One DVR image on the device (a [`DvrScene`] for a single render).
pub fn render(
    gpu: &Gpu,
    d: &Derivation,
    vol: &LatticeVolume,
    layout: Layout,
    tf: &TransferFunction,
    o: &DvrOptions,
) -> Result<Frame, GpuError> {
    DvrScene::new(gpu, d, vol, layout, o.block)?.render(tf, o)
}

/// The xyz of a uniform vector, widened to f64 (exactly).
fn d3(a: [f32; 4]) -> DVec3 {
    Vec3::from_slice(&a[..3]).as_dvec3()
}

/// The same renderer on the CPU in f64 with the exact evaluator
/// (`Derivation::eval_f64`), the same tables and no skipping (so matching
/// it also tests the skipping). Rows run on every core.
pub fn cpu_render(d: &Derivation, vol: &LatticeVolume, tf: &TransferFunction, o: &DvrOptions) -> Vec<u8> {
    let table = tf.table();
    let pi = o.preintegrate.then(|| table.preintegrate(o.step as f64));
    let p = dvr_params(d, vol, &table, pi.as_ref().map_or(2, |p| p.size), o);
    let data = |j: &[i64]| vol.get(j) as f64;
    let f = |x: DVec3| d.eval_f64(&x.to_array(), &data);
    let (w, h) = (o.width as usize, o.height as usize);
    let rows: Vec<usize> = (0..h).collect();
    let threads = std::thread::available_parallelism().map(|n| n.get()).unwrap_or(1);
    let mut out = vec![0u8; w * h * 4];
    std::thread::scope(|s| {
        let handles: Vec<_> = rows
            .chunks(h.div_ceil(threads).max(1))
            .map(|rows| {
                let (f, table, pi, p) = (&f, &table, pi.as_ref(), &p);
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
                            part.push((y, x, cast_ray(f, table, pi, origin, dir, p, o)));
                        }
                    }
                    part
                })
            })
            .collect();
        for hnd in handles {
            for (y, x, c) in hnd.join().expect("cpu dvr") {
                let i = (y * w + x) * 4;
                out[i..i + 4].copy_from_slice(&c);
            }
        }
    });
    out
}

fn cast_ray(
    f: &dyn Fn(DVec3) -> (f64, Vec<f64>),
    table: &Tf1d,
    pi: Option<&Preint>,
    origin: DVec3,
    dir: DVec3,
    p: &DvrParams,
    o: &DvrOptions,
) -> [u8; 4] {
    let at = |t: f64| origin + t * dir;
    let (mut t0, mut t1) = (0f64, f64::INFINITY);
    for i in 0..3 {
        let a = (p.box_lo[i] as f64 - origin[i]) / dir[i];
        let b = (p.box_hi[i] as f64 - origin[i]) / dir[i];
        t0 = t0.max(a.min(b));
        t1 = t1.min(a.max(b));
    }
    let up = d3(p.up);
    let l = {
        let v = -dir + 0.35 * up / up.length().max(1e-20);
        v / v.length()
    };
    let hv = {
        let v = l - dir;
        v / v.length()
    };
    let (ka, kd, ks, g0) = (p.light[0] as f64, p.light[1] as f64, p.light[2] as f64, p.light[3] as f64);
    let step = o.step as f64;
    let mut acc = DVec3::ZERO;
    let mut alpha = 0.0f64;
    if t0 < t1 {
        let nseg = ((t1 - t0) / step).floor() as i64;
        let (mut sf, g) = f(at(t0));
        let mut gf = DVec3::from_slice(&g);
        for k in 0..nseg {
            if alpha >= o.termination as f64 {
                break;
            }
            let (sb, g) = f(at(t0 + (k + 1) as f64 * step));
            let gb = DVec3::from_slice(&g);
            let (seg, g) = match pi {
                Some(pi) => (pi.at(sf, sb), 0.5 * (gf + gb)),
                None => {
                    let s = table.at(sb);
                    let a = 1.0 - (-s[3] * step).exp();
                    ([s[0] * a, s[1] * a, s[2] * a, a], gb)
                }
            };
            if seg[3] > 0.0 {
                let g2 = g.length_squared();
                let wgt = g2 / (g2 + g0 * g0);
                let n = g / g2.sqrt().max(1e-20);
                let diffuse = n.dot(l).abs();
                let specular = n.dot(hv).abs().powi(20);
                let c = DVec3::new(seg[0], seg[1], seg[2]);
                let lit = c * (ka + kd * diffuse) + DVec3::splat(seg[3] * ks * specular);
                acc += (1.0 - alpha) * (c + (lit - c) * wgt);
                alpha += (1.0 - alpha) * seg[3];
            }
            (sf, gf) = (sb, gb);
        }
    }
    let color = acc + (1.0 - alpha) * DVec3::from_array(BACKGROUND);
    let q = |v: f64| (v.clamp(0.0, 1.0) * 255.0 + 0.5) as u8;
    [q(color[0]), q(color[1]), q(color[2]), 255]
}

/// RMS difference of the RGB channels of two RGBA8 images, in 1/255 units.
pub fn rms(a: &[u8], b: &[u8]) -> f64 {
    assert_eq!(a.len(), b.len(), "images of the same size");
    let (mut sum, mut n) = (0.0, 0usize);
    for (pa, pb) in a.chunks(4).zip(b.chunks(4)) {
        for c in 0..3 {
            let dlt = pa[c] as f64 - pb[c] as f64;
            sum += dlt * dlt;
            n += 1;
        }
    }
    (sum / n.max(1) as f64).sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_uniform_matches_the_template_struct() {
        // Every field of `<f>_DvrParams` is a vec4 (16 bytes, no padding), in
        // the order of DvrParams.
        let t = dvr_template("f", false);
        let body = t.split("struct f_DvrParams {").nth(1).unwrap().split('}').next().unwrap();
        let fields: Vec<&str> = body.lines().map(str::trim).filter(|l| !l.is_empty() && !l.starts_with("//")).collect();
        assert!(fields.iter().all(|f| f.ends_with("vec4<f32>,") || f.ends_with("vec4<i32>,")), "{fields:?}");
        assert_eq!(fields.len() * 16, std::mem::size_of::<DvrParams>());
        let names: Vec<&str> = fields.iter().map(|f| f.split(':').next().unwrap()).collect();
        assert_eq!(
            names,
            ["eye", "forward", "right", "up", "box_lo", "box_hi", "tf", "mode", "light", "image", "blocks", "sizes"]
        );
    }

    #[test]
    fn widened_bounds_are_the_union_over_the_block_and_its_reach() {
        let dims = [7usize, 5, 6];
        let n = dims.iter().product::<usize>();
        let cells: Vec<[f32; 2]> = (0..n)
            .map(|i| {
                let v = ((i * 37) % 23) as f32;
                [v, v + ((i * 11) % 5) as f32]
            })
            .collect();
        for (block, reach) in [(2usize, 2usize), (4, 1), (3, 0)] {
            let got = widen_bounds(&cells, dims, block, reach);
            let blocks = dims.map(|d| d.div_ceil(block));
            assert_eq!(got.len(), blocks.iter().product::<usize>());
            for (k, g) in got.iter().enumerate() {
                let b = [k % blocks[0], (k / blocks[0]) % blocks[1], k / (blocks[0] * blocks[1])];
                let mut want = [f32::INFINITY, f32::NEG_INFINITY];
                for (i, c) in cells.iter().enumerate() {
                    let p = [i % dims[0], (i / dims[0]) % dims[1], i / (dims[0] * dims[1])];
                    let inside = (0..3).all(|a| p[a] + reach >= b[a] * block && p[a] < (b[a] + 1) * block + reach);
                    if inside {
                        want = [want[0].min(c[0]), want[1].max(c[1])];
                    }
                }
                assert_eq!(*g, want, "block {b:?}, edge {block}, reach {reach}");
            }
        }
    }

    #[test]
    fn skip_flags_shrink_the_empty_region_by_the_radius() {
        // 5 x 1 x 1 blocks: empty, empty, full, empty, empty.
        let empty = [1, 1, 0, 1, 1];
        assert_eq!(skip_flags(&empty, [5, 1, 1], 0), empty);
        assert_eq!(skip_flags(&empty, [5, 1, 1], 1), [1, 0, 0, 0, 1]);
        assert_eq!(skip_flags(&empty, [5, 1, 1], 2), [0, 0, 0, 0, 0]);
        // Along z in a 1 x 1 x 3 grid, and clamped at the faces.
        assert_eq!(skip_flags(&[1, 1, 0], [1, 1, 3], 1), [1, 0, 0]);
    }
}
