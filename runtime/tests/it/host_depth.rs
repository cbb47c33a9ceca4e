//! A host's depth buffer stops the rays (`encode_with_depth`): the host's
//! depth comes from a real depth pass (a tilted quad rasterized with the
//! camera's view-projection), the expected cut from the same plane
//! intersected with each pixel's ray on the CPU.

use boxforge::derive::Derivation;
use boxforge::emit::Layout;
use boxforge_runtime::gpu::Gpu;
use boxforge_runtime::render::camera::CameraUniform;
use boxforge_runtime::render::dvr::transfer::TransferFunction;
use boxforge_runtime::render::iso::HitMode;
use boxforge_runtime::render::{
    Camera, DvrLook, DvrRenderer, FrameCamera, HostDepth, IsoOptions, IsoRenderer, RenderError, Target,
};
use boxforge_runtime::volume::{DeviceVolume, LatticeVolume};
use glam::{Mat4, Vec3};

const SIZE: u32 = 96;
const FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba8Unorm;

/// Rasterizes a quad (corners in volume coordinates) into a Depth32Float
/// texture cleared to 1 (the far plane), depth test Less, as a host's
/// opaque pass would.
const QUAD: &str = r#"
struct Quad { vp: mat4x4<f32>, corners: array<vec4<f32>, 4> }
@group(0) @binding(0) var<uniform> q: Quad;
@vertex
fn vs(@builtin(vertex_index) i: u32) -> @builtin(position) vec4<f32> {
    return q.vp * vec4<f32>(q.corners[i].xyz, 1.0);
}
"#;

fn depth_texture(gpu: &Gpu, format: wgpu::TextureFormat, usage: wgpu::TextureUsages, size: u32) -> wgpu::Texture {
    gpu.device.create_texture(&wgpu::TextureDescriptor {
        label: Some("host depth"),
        size: wgpu::Extent3d { width: size, height: size, depth_or_array_layers: 1 },
        mip_level_count: 1,
        sample_count: 1,
        dimension: wgpu::TextureDimension::D2,
        format,
        usage,
        view_formats: &[],
    })
}

/// The host's depth pass: `quad` (strip order) drawn with `vp`, or nothing
/// (only the clear) for `None`.
fn host_depth(gpu: &Gpu, vp: Mat4, quad: Option<[Vec3; 4]>) -> wgpu::Texture {
    let usage = wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::TEXTURE_BINDING;
    let texture = depth_texture(gpu, wgpu::TextureFormat::Depth32Float, usage, SIZE);
    let view = texture.create_view(&Default::default());
    let dev = &gpu.device;
    let shader = dev.create_shader_module(wgpu::ShaderModuleDescriptor {
        label: Some("quad"),
        source: wgpu::ShaderSource::Wgsl(QUAD.into()),
    });
    let pipeline = dev.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
        label: Some("quad"),
        layout: None,
        vertex: wgpu::VertexState {
            module: &shader,
            entry_point: Some("vs"),
            compilation_options: Default::default(),
            buffers: &[],
        },
        fragment: None,
        primitive: wgpu::PrimitiveState { topology: wgpu::PrimitiveTopology::TriangleStrip, ..Default::default() },
        depth_stencil: Some(wgpu::DepthStencilState {
            format: wgpu::TextureFormat::Depth32Float,
            depth_write_enabled: Some(true),
            depth_compare: Some(wgpu::CompareFunction::Less),
            stencil: Default::default(),
            bias: Default::default(),
        }),
        multisample: Default::default(),
        multiview_mask: None,
        cache: None,
    });
    let corners = quad.unwrap_or([Vec3::ZERO; 4]);
    let mut data: Vec<f32> = vp.to_cols_array().to_vec();
    for c in corners {
        data.extend(c.extend(1.0).to_array());
    }
    let uniform = gpu.uniform_buffer("quad", bytemuck::cast_slice(&data));
    let bind = dev.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("quad"),
        layout: &pipeline.get_bind_group_layout(0),
        entries: &[wgpu::BindGroupEntry { binding: 0, resource: uniform.as_entire_binding() }],
    });
    let mut encoder = dev.create_command_encoder(&Default::default());
    {
        let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("host depth"),
            color_attachments: &[],
            depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                view: &view,
                depth_ops: Some(wgpu::Operations { load: wgpu::LoadOp::Clear(1.0), store: wgpu::StoreOp::Store }),
                stencil_ops: None,
            }),
            timestamp_writes: None,
            occlusion_query_set: None,
            multiview_mask: None,
        });
        if quad.is_some() {
            pass.set_pipeline(&pipeline);
            pass.set_bind_group(0, &bind, &[]);
            pass.draw(0..4, 0..1);
        }
    }
    gpu.queue.submit([encoder.finish()]);
    texture
}

/// A plane through `point` with unit normal `n`, as a quad of half-edge `half`.
fn quad(point: Vec3, n: Vec3, half: f32) -> [Vec3; 4] {
    let u = n.any_orthonormal_vector();
    let v = n.cross(u);
    [point - half * (u + v), point + half * (u - v), point - half * (u - v), point + half * (u + v)]
}

fn v3(a: [f32; 4]) -> Vec3 {
    Vec3::new(a[0], a[1], a[2])
}

/// Pixel (x, y)'s ray (origin, unit direction) and its entry and exit of the valid box.
fn ray(c: &CameraUniform, perspective: bool, x: u32, y: u32) -> (Vec3, Vec3, f32, f32) {
    let sx = (x as f32 + 0.5) / SIZE as f32 * 2.0 - 1.0;
    let sy = 1.0 - (y as f32 + 0.5) / SIZE as f32 * 2.0;
    let (o, d) = if perspective {
        (v3(c.eye), (v3(c.forward) + sx * v3(c.right) + sy * v3(c.up)).normalize())
    } else {
        (v3(c.eye) + sx * v3(c.right) + sy * v3(c.up), v3(c.forward))
    };
    let (ta, tb) = ((v3(c.box_lo) - o) / d, (v3(c.box_hi) - o) / d);
    (o, d, ta.min(tb).max_element().max(0.0), ta.max(tb).min_element())
}

/// Where the plane (point, n) crosses each pixel's ray, `None` where the
/// host's pass does not draw it (behind the eye or outside near..far,
/// with a margin).
fn plane_t(c: &CameraUniform, perspective: bool, vp: Mat4, point: Vec3, n: Vec3) -> Vec<Option<f32>> {
    (0..SIZE * SIZE)
        .map(|i| {
            let (o, d, _, _) = ray(c, perspective, i % SIZE, i / SIZE);
            let t = (point - o).dot(n) / d.dot(n);
            let clip = vp * (o + t * d).extend(1.0);
            let z = clip.z / clip.w;
            (t > 0.0 && clip.w > 0.0 && (0.001..0.999).contains(&z)).then_some(t)
        })
        .collect()
}

fn words(gpu: &Gpu, buffer: &wgpu::Buffer) -> Vec<u32> {
    bytemuck::cast_slice(&gpu.read_buffer(buffer).unwrap()).to_vec()
}

struct Host {
    gpu: &'static Gpu,
    d: Derivation,
    volume: DeviceVolume,
    target: wgpu::Texture,
}

fn host() -> Host {
    let gpu = crate::common::gpu();
    let d = Derivation::new(&boxforge::spec::catalog::get("bcc7").unwrap()).unwrap();
    let samples = LatticeVolume::marschner_lobb(&d.filter.lattice, [24, 24, 24]).unwrap();
    let volume = DeviceVolume::new(gpu, &samples, Layout::Embedded).unwrap();
    let target = gpu.device.create_texture(&wgpu::TextureDescriptor {
        label: Some("host colour"),
        size: wgpu::Extent3d { width: SIZE, height: SIZE, depth_or_array_layers: 1 },
        mip_level_count: 1,
        sample_count: 1,
        dimension: wgpu::TextureDimension::D2,
        format: FORMAT,
        usage: wgpu::TextureUsages::RENDER_ATTACHMENT,
        view_formats: &[],
    });
    Host { gpu, d, volume, target }
}

/// What a frame's `encode_with_depth` is called with.
type Frame<'a> = (FrameCamera, Option<&'a wgpu::Texture>);

fn iso_frame(h: &Host, r: &mut IsoRenderer, (camera, depth): Frame<'_>) -> (Vec<u32>, Vec<f32>) {
    let view = h.target.create_view(&Default::default());
    let depth_view = depth.map(|t| t.create_view(&Default::default()));
    let mut encoder = h.gpu.device.create_command_encoder(&Default::default());
    let target = Target { view: &view, format: FORMAT, width: SIZE, height: SIZE };
    r.encode_with_depth(&mut encoder, &target, camera, depth_view.as_ref().map(|view| HostDepth { view })).unwrap();
    h.gpu.queue.submit([encoder.finish()]);
    let t = words(h.gpu, r.depth_buffer().unwrap()).into_iter().map(f32::from_bits).collect();
    (words(h.gpu, r.image_buffer().unwrap()), t)
}

#[test]
fn iso_hits_stop_at_the_hosts_plane_and_keep_the_ones_in_front() {
    let h = host();
    for (hit, perspective) in [(HitMode::Step, false), (HitMode::Step, true), (HitMode::Exact, false)] {
        let mut r = IsoRenderer::new(h.gpu, &h.d, &h.volume, IsoOptions { hit, ..IsoOptions::default() }).unwrap();
        let (lo, hi) = r.valid_box();
        let camera = Camera { perspective, ..Camera::default() };
        let c = CameraUniform::orbit(&camera, lo, hi, SIZE, SIZE);
        let vp = camera.view_projection(lo, hi, SIZE, SIZE);
        let (image0, t0) = iso_frame(&h, &mut r, (camera.into(), None));
        // The far plane only: every hit kept, misses transparent.
        let far = host_depth(h.gpu, vp, None);
        let (image_far, t_far) = iso_frame(&h, &mut r, (camera.into(), Some(&far)));
        assert_eq!(t_far, t0, "perspective {perspective}: a cleared host depth changes no hit");
        for i in 0..image0.len() {
            assert_eq!(image_far[i], if t0[i] >= 0.0 { image0[i] } else { 0 }, "pixel {i}");
        }
        // A tilted plane through the centre of the volume.
        let centre = (Vec3::from(lo) + Vec3::from(hi)) * 0.5;
        let n = (v3(c.forward).normalize() + 0.6 * v3(c.right).normalize() + 0.3 * v3(c.up).normalize()).normalize();
        let half = 3.0 * (Vec3::from(hi) - Vec3::from(lo)).length();
        let plane = host_depth(h.gpu, vp, Some(quad(centre, n, half)));
        let (image1, t1) = iso_frame(&h, &mut r, (camera.into(), Some(&plane)));
        let tp = plane_t(&c, perspective, vp, centre, n);
        let (mut kept, mut cut) = (0, 0);
        for i in 0..t0.len() {
            let Some(tp) = tp[i] else { continue };
            // Depth32Float and the unprojection in f32: about 1e-4 cell here.
            let eps = 0.01;
            assert!(t1[i] <= tp + eps, "pixel {i}: hit at {} behind the plane at {tp}", t1[i]);
            if t0[i] >= 0.0 && t0[i] < tp - eps {
                assert_eq!((t1[i], image1[i]), (t0[i], image0[i]), "pixel {i}: a hit in front of the plane changed");
                kept += 1;
            } else if t0[i] > tp + eps {
                assert_eq!(
                    (t1[i], image1[i]),
                    (-1.0, 0),
                    "pixel {i}: the hit at {} is behind the plane at {tp}",
                    t0[i]
                );
                cut += 1;
            }
        }
        eprintln!(
            "{hit:?}, perspective {perspective}: {kept} hits in front of the plane kept, {cut} behind it removed"
        );
        assert!(kept > 300 && cut > 300, "the plane cuts the surface ({kept} kept, {cut} cut)");
        // Back to frames without a host depth: the first image again.
        assert_eq!(iso_frame(&h, &mut r, (camera.into(), None)), (image0, t0));
    }
}

#[test]
fn a_host_view_projection_gives_the_orbits_rays() {
    // The host's matrix of the orbit, handed over as a host camera: the
    // rays are rebuilt from it (to rounding), so the image is the orbit's
    // up to the odd pixel on a silhouette.
    let h = host();
    let mut r = IsoRenderer::new(h.gpu, &h.d, &h.volume, IsoOptions::default()).unwrap();
    let (lo, hi) = r.valid_box();
    for perspective in [false, true] {
        let camera = Camera { perspective, ..Camera::default() };
        let (_, t0) = iso_frame(&h, &mut r, (camera.into(), None));
        let vp = camera.view_projection(lo, hi, SIZE, SIZE);
        let (_, t1) = iso_frame(&h, &mut r, (FrameCamera::ViewProj(vp), None));
        let hits = t0.iter().filter(|&&t| t >= 0.0).count();
        let differ = t0.iter().zip(&t1).filter(|(a, b)| (**a < 0.0) != (**b < 0.0) || (**a - **b).abs() > 0.01).count();
        assert!(hits > 1000, "the surface is in view ({hits} pixels)");
        assert!(differ <= hits / 100, "perspective {perspective}: {differ} of {hits} hits differ");
    }
}

#[test]
fn dvr_composites_up_to_the_hosts_plane() {
    let h = host();
    let tf = TransferFunction::preset("marschner-lobb");
    let mut r = DvrRenderer::new(h.gpu, &h.d, &h.volume, &tf, DvrLook::default()).unwrap();
    let (lo, hi) = r.valid_box();
    let camera = Camera::default();
    let c = CameraUniform::orbit(&camera, lo, hi, SIZE, SIZE);
    let vp = camera.view_projection(lo, hi, SIZE, SIZE);
    let frame = |r: &mut DvrRenderer, depth: Option<&wgpu::Texture>| -> Vec<[u8; 4]> {
        let view = h.target.create_view(&Default::default());
        let depth_view = depth.map(|t| t.create_view(&Default::default()));
        let mut encoder = h.gpu.device.create_command_encoder(&Default::default());
        let target = Target { view: &view, format: FORMAT, width: SIZE, height: SIZE };
        let host = depth_view.as_ref().map(|view| HostDepth { view });
        r.encode_with_depth(&mut encoder, &target, camera.into(), host).unwrap();
        h.gpu.queue.submit([encoder.finish()]);
        words(h.gpu, r.image_buffer().unwrap()).into_iter().map(u32::to_le_bytes).collect()
    };
    let plain = frame(&mut r, None);
    let far = frame(&mut r, Some(&host_depth(h.gpu, vp, None)));
    // Premultiplied over the background is the plain frame (to the 8-bit
    // rounding of opacity and colour).
    let bg = [20.4f32, 20.4, 25.5];
    let mut worst = 0f32;
    for (p, f) in plain.iter().zip(&far) {
        for k in 0..3 {
            worst = worst.max((p[k] as f32 - (f[k] as f32 + (1.0 - f[3] as f32 / 255.0) * bg[k])).abs());
        }
    }
    assert!(worst <= 1.5, "over the background the composited frame is the plain one ({worst}/255)");
    let covered = far.iter().filter(|p| p[3] > 0).count();
    assert!(covered > 2000, "the volume is in view ({covered} pixels)");
    let forward = v3(c.forward).normalize();
    let centre = (Vec3::from(lo) + Vec3::from(hi)) * 0.5;
    let radius = 0.5 * (Vec3::from(hi) - Vec3::from(lo)).length();
    let half = 3.0 * radius;
    // A plane behind the whole volume changes no pixel.
    let behind =
        frame(&mut r, Some(&host_depth(h.gpu, vp, Some(quad(centre + 1.5 * radius * forward, forward, half)))));
    assert!(behind == far, "a plane behind the volume changed the frame");
    // A plane in front of it leaves nothing to composite.
    let front = frame(&mut r, Some(&host_depth(h.gpu, vp, Some(quad(centre - 1.2 * radius * forward, forward, half)))));
    assert!(front.iter().all(|p| *p == [0; 4]), "a plane in front of the volume left pixels");
    // A tilted plane through the centre: no more opacity or colour than
    // without it anywhere, the same where it lies behind the ray's exit.
    let n = (forward + 0.6 * v3(c.right).normalize() + 0.3 * v3(c.up).normalize()).normalize();
    let cut = frame(&mut r, Some(&host_depth(h.gpu, vp, Some(quad(centre, n, half)))));
    let tp = plane_t(&c, false, vp, centre, n);
    let (mut same, mut less, mut empty) = (0, 0, 0);
    for i in 0..cut.len() {
        assert!((0..4).all(|k| cut[i][k] <= far[i][k]), "pixel {i}: {:?} over {:?} without the plane", cut[i], far[i]);
        let (_, _, entry, exit) = ray(&c, false, i as u32 % SIZE, i as u32 / SIZE);
        match tp[i] {
            Some(t) if t > exit + 0.01 => {
                assert_eq!(cut[i], far[i], "pixel {i}: the plane at {t} lies behind the exit at {exit}");
                same += (far[i][3] > 0) as usize;
            }
            Some(t) if t < entry - 0.01 => {
                assert_eq!(cut[i], [0; 4], "pixel {i}: the plane at {t} lies in front of the entry at {entry}");
                empty += (far[i][3] > 0) as usize;
            }
            None => {}
            _ => less += (cut[i][3] < far[i][3]) as usize,
        }
    }
    eprintln!(
        "DVR: of the pixels the volume covers, {same} with the plane behind the exit unchanged, {empty} with it in front of the entry empty, {less} with less opacity"
    );
    assert!(
        same > 300 && empty > 300 && less > 1000,
        "the plane cuts the volume ({same} same, {empty} empty, {less} less)"
    );
    // Back to frames without a host depth.
    assert!(frame(&mut r, None) == plain);
}

#[test]
fn a_host_depth_of_the_wrong_kind_is_a_typed_error() {
    let h = host();
    let mut r = IsoRenderer::new(h.gpu, &h.d, &h.volume, IsoOptions::default()).unwrap();
    let view = h.target.create_view(&Default::default());
    let binding = wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::RENDER_ATTACHMENT;
    let cases = [
        (wgpu::TextureFormat::Depth24PlusStencil8, binding, SIZE),
        (wgpu::TextureFormat::R32Float, binding, SIZE),
        (wgpu::TextureFormat::Depth32Float, wgpu::TextureUsages::RENDER_ATTACHMENT, SIZE),
        (wgpu::TextureFormat::Depth32Float, binding, SIZE / 2),
    ];
    for (i, (format, usage, size)) in cases.into_iter().enumerate() {
        let texture = depth_texture(h.gpu, format, usage, size);
        let depth = texture.create_view(&wgpu::TextureViewDescriptor {
            aspect: if format.has_depth_aspect() { wgpu::TextureAspect::DepthOnly } else { wgpu::TextureAspect::All },
            ..Default::default()
        });
        let mut encoder = h.gpu.device.create_command_encoder(&Default::default());
        let target = Target { view: &view, format: FORMAT, width: SIZE, height: SIZE };
        let e = r
            .encode_with_depth(&mut encoder, &target, Camera::default().into(), Some(HostDepth { view: &depth }))
            .unwrap_err();
        let expected = match i {
            0 | 1 => matches!(e, RenderError::HostDepthFormat { format: f } if f == format),
            2 => matches!(e, RenderError::HostDepthUsage { .. }),
            _ => matches!(e, RenderError::HostDepthSize { depth: [48, 48], target: [96, 96], .. }),
        };
        assert!(expected, "{format:?} {usage:?} {size}: {e}");
        assert!(!e.to_string().contains("--"), "a library message names no flag: {e}");
    }
}
