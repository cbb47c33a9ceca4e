//! Isosurface rendering: the emitted filter module plus the ray-casting
//! template (`templates/raycast.wgsl.j2`), the BB min/max block grid from the
//! emitted min/max kernel, and a CPU reference ray caster for tests.

use crate::gpu::{Gpu, GpuError};
use crate::upload::{storage_entry, uniform_entry, DeviceVolume};
use crate::volume::LatticeVolume;
use boxforge::derive::Derivation;
use boxforge::emit::{emit, EmitOptions, Layout};
use glam::{DVec3, Vec3};
use std::time::Instant;

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
        }
    }
}

/// The uniform block of the ray caster (layout checked against naga in tests).
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
pub struct RayParams {
    pub eye: [f32; 4],
    pub forward: [f32; 4],
    pub right: [f32; 4],
    pub up: [f32; 4],
    pub box_lo: [f32; 4],
    pub box_hi: [f32; 4],
    pub shade: [f32; 4],
    pub image: [i32; 4],
    pub blocks: [i32; 4],
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

/// The uniform layout of a direction or position: xyz and a zero w.
fn v4(a: Vec3) -> [f32; 4] {
    a.extend(0.0).to_array()
}

/// The xyz of a uniform vector, widened to f64 (exactly).
fn d3(a: [f32; 4]) -> DVec3 {
    Vec3::from_slice(&a[..3]).as_dvec3()
}

/// [`valid_box`] as glam vectors.
fn valid_box_vec(d: &Derivation, vol: &LatticeVolume) -> (Vec3, Vec3) {
    let r = crate::verify::support_radius(d) as f32;
    let dims = Vec3::new(vol.dims[0] as f32, vol.dims[1] as f32, vol.dims[2] as f32);
    (Vec3::splat(r), dims - 1.0 - r)
}

/// The box where the whole support of every sample used lies in the volume.
pub fn valid_box(d: &Derivation, vol: &LatticeVolume) -> ([f32; 3], [f32; 3]) {
    let (lo, hi) = valid_box_vec(d, vol);
    (lo.to_array(), hi.to_array())
}

pub fn ray_params(d: &Derivation, vol: &LatticeVolume, o: &RenderOptions) -> RayParams {
    let (lo, hi) = valid_box_vec(d, vol);
    let center = (lo + hi) * 0.5;
    let radius = 0.5 * (hi - lo).length();
    let (az, el) = (o.azimuth.to_radians(), o.elevation.to_radians());
    let toward_eye = Vec3::new(el.cos() * az.cos(), el.cos() * az.sin(), el.sin());
    let forward = -toward_eye;
    let world_up = if el.cos().abs() < 1e-3 { Vec3::Y } else { Vec3::Z };
    // Divide by the (guarded) length rather than glam's normalize, which
    // multiplies by its reciprocal and rounds differently.
    let right = {
        let c = forward.cross(world_up);
        c / c.length().max(1e-20)
    };
    let up = right.cross(forward);
    let aspect = o.width as f32 / o.height as f32;
    let (eye, half) = if o.perspective {
        let dist = radius * 2.6;
        (center - forward * dist, (22.5f32).to_radians().tan())
    } else {
        (center - forward * (radius * 2.0), radius * 1.05)
    };
    let blocks = [
        (vol.dims[0] as i32 + o.block - 1) / o.block,
        (vol.dims[1] as i32 + o.block - 1) / o.block,
        (vol.dims[2] as i32 + o.block - 1) / o.block,
        0,
    ];
    RayParams {
        eye: v4(eye),
        forward: v4(forward),
        right: v4(right * (half * aspect)),
        up: v4(up * half),
        box_lo: v4(lo),
        box_hi: v4(hi),
        shade: [o.iso, o.step, o.perspective as i32 as f32, o.skip as i32 as f32],
        image: [o.width as i32, o.height as i32, o.block, 0],
        blocks,
    }
}

fn template(name: &str) -> String {
    let env = {
        let mut env = minijinja::Environment::new();
        env.add_template("raycast", include_str!("../../templates/raycast.wgsl.j2")).expect("template");
        env
    };
    env.get_template("raycast").unwrap().render(minijinja::context! { name => name }).expect("render")
}

/// Renders one isosurface image on the device.
pub fn render(
    gpu: &Gpu,
    d: &Derivation,
    vol: &LatticeVolume,
    layout: Layout,
    o: &RenderOptions,
) -> Result<Frame, GpuError> {
    let name = &d.filter.name;
    let module = emit(d, &EmitOptions { layout, command: "boxforge render".into(), ..Default::default() })
        .map_err(|e| GpuError::Runtime(e.to_string()))?;
    let source = format!("{}\n{}", module.source, template(name));
    let shader = gpu.compile(&format!("{name}.raycast.wgsl"), &source)?;
    let dev = &gpu.device;
    let dv = DeviceVolume::new(gpu, vol, layout)?;
    let params = ray_params(d, vol, o);
    let nblocks = (params.blocks[0] * params.blocks[1] * params.blocks[2]) as usize;
    let out_binding = if layout == Layout::Packed { 2 } else { 1 };

    // Min/max block grid with the emitted kernel.
    let mut entries0 = dv.layout_entries(0, wgpu::ShaderStages::COMPUTE);
    entries0.push(storage_entry(out_binding, false));
    entries0.push(uniform_entry(out_binding + 1));
    let bgl_mm =
        dev.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor { label: Some("minmax"), entries: &entries0 });
    let blocks_buf = gpu.storage_buffer("blocks", &vec![0u8; nblocks * 8], true);
    let job: [i32; 8] = [0, 0, 0, 0, params.blocks[0], params.blocks[1], params.blocks[2], o.block];
    let job_buf = gpu.uniform_buffer("job", bytemuck::cast_slice(&job));
    let mut bind0 = dv.bind_entries(0);
    bind0.push(wgpu::BindGroupEntry { binding: out_binding, resource: blocks_buf.as_entire_binding() });
    bind0.push(wgpu::BindGroupEntry { binding: out_binding + 1, resource: job_buf.as_entire_binding() });
    let bg_mm =
        dev.create_bind_group(&wgpu::BindGroupDescriptor { label: Some("minmax"), layout: &bgl_mm, entries: &bind0 });
    let minmax = gpu.pipeline("minmax", &shader, &[&bgl_mm], &format!("{name}_minmax_main"))?;
    gpu.dispatch("minmax", &minmax, &[&bg_mm], ((nblocks as u32).div_ceil(64), 1, 1))?;
    let bounds: Vec<f32> = bytemuck::cast_slice(&gpu.read_buffer(&blocks_buf)?).to_vec();
    let empty = bounds.chunks(2).filter(|b| o.iso < b[0] || o.iso > b[1]).count() as f64 / nblocks.max(1) as f64;

    // Ray casting.
    let bgl_s = dev.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
        label: Some("samples"),
        entries: &dv.layout_entries(0, wgpu::ShaderStages::COMPUTE),
    });
    let bgl_rc = dev.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
        label: Some("raycast"),
        entries: &[uniform_entry(0), storage_entry(1, false), storage_entry(2, true)],
    });
    let raycast = gpu.pipeline("raycast", &shader, &[&bgl_s, &bgl_rc], &format!("{name}_raycast_main"))?;
    let pixels = (o.width * o.height) as usize;
    let params_buf = gpu.uniform_buffer("params", bytemuck::bytes_of(&params));
    let image = gpu.storage_buffer("image", &vec![0u8; pixels * 4], true);
    let bg_s =
        dev.create_bind_group(&wgpu::BindGroupDescriptor { label: None, layout: &bgl_s, entries: &dv.bind_entries(0) });
    let bg_rc = dev.create_bind_group(&wgpu::BindGroupDescriptor {
        label: None,
        layout: &bgl_rc,
        entries: &[
            wgpu::BindGroupEntry { binding: 0, resource: params_buf.as_entire_binding() },
            wgpu::BindGroupEntry { binding: 1, resource: image.as_entire_binding() },
            wgpu::BindGroupEntry { binding: 2, resource: blocks_buf.as_entire_binding() },
        ],
    });
    // One dispatch per frame, or bands of rows with a progress line.
    let band = if o.progress { 32u32 } else { o.height };
    let frame = |report: bool| -> Result<f64, GpuError> {
        let start = Instant::now();
        let bar = if report {
            crate::progress::bar(o.height as u64, "rendering rows")
        } else {
            indicatif::ProgressBar::hidden()
        };
        let mut y0 = 0u32;
        while y0 < o.height {
            let rows = band.min(o.height - y0);
            let mut p = params;
            p.image[3] = y0 as i32;
            gpu.queue.write_buffer(&params_buf, 0, bytemuck::bytes_of(&p));
            let mut enc = dev.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("raycast") });
            {
                let mut pass =
                    enc.begin_compute_pass(&wgpu::ComputePassDescriptor { label: None, timestamp_writes: None });
                pass.set_pipeline(&raycast);
                pass.set_bind_group(0, &bg_s, &[]);
                pass.set_bind_group(1, &bg_rc, &[]);
                pass.dispatch_workgroups(o.width.div_ceil(8), rows.div_ceil(8), 1);
            }
            gpu.queue.submit([enc.finish()]);
            gpu.wait()?;
            y0 += rows;
            bar.set_position(y0 as u64);
        }
        bar.finish_and_clear();
        Ok(start.elapsed().as_secs_f64() * 1e3)
    };
    gpu.checked("raycast warm-up", || frame(o.progress))??;
    let mut times: Vec<f64> = (0..o.frames.max(1)).map(|_| frame(false)).collect::<Result<_, _>>()?;
    times.sort_by(|a, b| a.total_cmp(b));
    let words: Vec<u32> = bytemuck::cast_slice(&gpu.read_buffer(&image)?).to_vec();
    let rgba = words.iter().flat_map(|w| w.to_le_bytes()).collect();
    Ok(Frame { width: o.width, height: o.height, rgba, ms_per_frame: times[times.len() / 2], empty_blocks: empty })
}

/// The same ray caster on the CPU with the exact evaluator in f64 (no
/// skipping: it must give the same image, which tests the skipping too).
pub fn cpu_render(d: &Derivation, vol: &LatticeVolume, o: &RenderOptions) -> Vec<u8> {
    let p = ray_params(d, vol, o);
    let data = |j: &[i64]| vol.get(j) as f64;
    let f = |x: DVec3| d.eval_f64(&x.to_array(), &data);
    let (w, h) = (o.width as usize, o.height as usize);
    let rows: Vec<usize> = (0..h).collect();
    let threads = std::thread::available_parallelism().map(|n| n.get()).unwrap_or(1);
    let chunks: Vec<Vec<usize>> = rows.chunks(h.div_ceil(threads)).map(|c| c.to_vec()).collect();
    let mut out = vec![0u8; w * h * 4];
    std::thread::scope(|s| {
        let handles: Vec<_> = chunks
            .iter()
            .map(|rows| {
                let f = &f;
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
                            let c = cast_ray(f, origin, dir, &p, o);
                            part.push((y, x, c));
                        }
                    }
                    part
                })
            })
            .collect();
        for hnd in handles {
            for (y, x, c) in hnd.join().expect("cpu ray cast") {
                let i = (y * w + x) * 4;
                out[i..i + 4].copy_from_slice(&c);
            }
        }
    });
    out
}

fn cast_ray(
    f: &dyn Fn(DVec3) -> (f64, Vec<f64>),
    origin: DVec3,
    dir: DVec3,
    p: &RayParams,
    o: &RenderOptions,
) -> [u8; 4] {
    let at = |t: f64| origin + t * dir;
    let (mut t0, mut t1) = (0f64, f64::INFINITY);
    for i in 0..3 {
        let a = (p.box_lo[i] as f64 - origin[i]) / dir[i];
        let b = (p.box_hi[i] as f64 - origin[i]) / dir[i];
        t0 = t0.max(a.min(b));
        t1 = t1.min(a.max(b));
    }
    let mut color = DVec3::new(0.08, 0.08, 0.1);
    if t0 < t1 {
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
        if let Some((mut a, mut b)) = hit {
            let sa = f(at(a)).0 - iso < 0.0;
            while b - a >= 1e-4 {
                let m = 0.5 * (a + b);
                if (f(at(m)).0 - iso < 0.0) == sa {
                    a = m;
                } else {
                    b = m;
                }
            }
            // Normalised by dividing by the length (not glam's normalize,
            // which multiplies by the reciprocal) to keep the rounding.
            let g = DVec3::from_slice(&f(at(0.5 * (a + b))).1);
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
    [q(color[0]), q(color[1]), q(color[2]), 255]
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
