//! The per-frame renderers of PERM, projected tetrahedra and the
//! hand-written schemes: a frame encoded into a host's Rgba8Unorm texture
//! is the one-shot (CLI) image, and frames after the first create no
//! buffer, texture, view, bind group, pipeline or shader module while the
//! camera moves (wgpu's own object counters, on a device of the test's own
//! so that the tests running beside it do not move them).

use boxforge::derive::Derivation;
use boxforge::emit::Layout;
use boxforge_runtime::gpu::Gpu;
use boxforge_runtime::render::dvr::transfer::TransferFunction;
use boxforge_runtime::render::dvr::{rms, DvrLook, DvrOptions, DvrScene};
use boxforge_runtime::render::perm::{PermRenderer, Quant};
use boxforge_runtime::render::pt::render::{Normals, Shading};
use boxforge_runtime::render::pt::{PtOptions, PtRenderer};
use boxforge_runtime::render::schemes::{self, Scheme, SchemeRenderer};
use boxforge_runtime::render::{Camera, RenderError, Target};
use boxforge_runtime::volume::{DeviceVolume, LatticeVolume};

const SIZE: u32 = 48;
const FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba8Unorm;

fn derive(name: &str) -> Derivation {
    Derivation::new(&boxforge::spec::catalog::get(name).unwrap()).unwrap()
}

/// Marschner-Lobb's shell around 0.5 and a faint one around 0.75: most
/// cells are transparent, so the skipping, the cache's selection and the
/// tetrahedra's visibility masks all have something to leave out.
fn shells() -> TransferFunction {
    TransferFunction::parse(
        r#"{"range": [0, 1], "points": [
            {"value": 0.0, "color": [0.2, 0.4, 0.9], "opacity": 0.0},
            {"value": 0.44, "color": [0.9, 0.6, 0.3], "opacity": 0.0},
            {"value": 0.5, "color": [1.0, 0.7, 0.3], "opacity": 0.6},
            {"value": 0.56, "color": [1.0, 0.7, 0.3], "opacity": 0.0},
            {"value": 0.7, "color": [0.9, 0.2, 0.2], "opacity": 0.0},
            {"value": 0.75, "color": [0.9, 0.2, 0.2], "opacity": 0.2},
            {"value": 0.8, "color": [0.9, 0.2, 0.2], "opacity": 0.0},
            {"value": 1.0, "color": [1.0, 1.0, 1.0], "opacity": 0.0}]}"#,
        "shells",
    )
    .unwrap()
}

/// The one-shot options of `camera` at SIZE.
fn options(camera: &Camera) -> DvrOptions {
    DvrOptions {
        width: SIZE,
        height: SIZE,
        azimuth: camera.azimuth,
        elevation: camera.elevation,
        perspective: camera.perspective,
        frames: 0,
        ..DvrOptions::default()
    }
}

fn look(o: &DvrOptions) -> DvrLook {
    DvrLook {
        step: o.step,
        block: o.block,
        skip: o.skip,
        skip_map: o.skip_map,
        preintegrate: o.preintegrate,
        termination: o.termination,
        curvature: o.curvature,
    }
}

/// A host's colour target: render attachment, and copy source to read it back.
fn target(gpu: &Gpu) -> wgpu::Texture {
    target_of(gpu, FORMAT)
}

fn target_of(gpu: &Gpu, format: wgpu::TextureFormat) -> wgpu::Texture {
    gpu.device.create_texture(&wgpu::TextureDescriptor {
        label: Some("host target"),
        size: wgpu::Extent3d { width: SIZE, height: SIZE, depth_or_array_layers: 1 },
        mip_level_count: 1,
        sample_count: 1,
        dimension: wgpu::TextureDimension::D2,
        format,
        usage: wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::COPY_SRC,
        view_formats: &[],
    })
}

/// The target's RGBA8 texels, rows from the top.
fn read(gpu: &Gpu, texture: &wgpu::Texture) -> Vec<u8> {
    let row = (SIZE * 4).next_multiple_of(wgpu::COPY_BYTES_PER_ROW_ALIGNMENT);
    let buffer = gpu.device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("target readback"),
        size: (row * SIZE) as u64,
        usage: wgpu::BufferUsages::COPY_SRC | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    let mut enc = gpu.device.create_command_encoder(&Default::default());
    enc.copy_texture_to_buffer(
        texture.as_image_copy(),
        wgpu::TexelCopyBufferInfo {
            buffer: &buffer,
            layout: wgpu::TexelCopyBufferLayout { offset: 0, bytes_per_row: Some(row), rows_per_image: Some(SIZE) },
        },
        wgpu::Extent3d { width: SIZE, height: SIZE, depth_or_array_layers: 1 },
    );
    gpu.queue.submit([enc.finish()]);
    let bytes = gpu.read_buffer(&buffer).unwrap();
    bytes.chunks(row as usize).flat_map(|r| r[..SIZE as usize * 4].to_vec()).collect()
}

/// One frame of `encode` into a fresh host target, read back.
fn host_frame(
    gpu: &Gpu,
    encode: impl FnOnce(&mut wgpu::CommandEncoder, &Target<'_>) -> Result<(), RenderError>,
) -> Vec<u8> {
    host_frame_in(gpu, FORMAT, encode)
}

/// [`host_frame`] into a target of `format` (Rgba8 or Bgra8), as RGBA.
fn host_frame_in(
    gpu: &Gpu,
    format: wgpu::TextureFormat,
    encode: impl FnOnce(&mut wgpu::CommandEncoder, &Target<'_>) -> Result<(), RenderError>,
) -> Vec<u8> {
    let texture = target_of(gpu, format);
    let view = texture.create_view(&Default::default());
    let mut enc = gpu.device.create_command_encoder(&Default::default());
    encode(&mut enc, &Target { view: &view, format, width: SIZE, height: SIZE }).unwrap();
    gpu.queue.submit([enc.finish()]);
    let mut texels = read(gpu, &texture);
    if matches!(format, wgpu::TextureFormat::Bgra8Unorm | wgpu::TextureFormat::Bgra8UnormSrgb) {
        texels.chunks_mut(4).for_each(|p| p.swap(0, 2));
    }
    texels
}

/// Pixels away from the background (20, 20, 26) by more than 2 levels.
fn shown(img: &[u8]) -> usize {
    let bg = [20i32, 20, 26];
    img.chunks(4).filter(|p| (0..3).any(|c| (p[c] as i32 - bg[c]).abs() > 2)).count()
}

fn check(what: &str, frame: &[u8], one_shot: &[u8]) {
    let e = rms(frame, one_shot);
    eprintln!("{what}: host frame vs one-shot image RMS {e:.4}/255, {} pixels shown", shown(one_shot));
    assert!(shown(one_shot) > (SIZE * SIZE / 10) as usize, "{what}: the volume is in view");
    assert!(e < 0.5, "{what}: RMS {e:.3}/255 between the host's frame and the one-shot image");
}

#[test]
fn a_perm_frame_in_a_host_target_is_the_one_shot_image() {
    let gpu = crate::common::gpu();
    let d = derive("bcc7");
    let vol = LatticeVolume::marschner_lobb(&d.filter.lattice, [16, 16, 16]).unwrap();
    let camera = Camera { azimuth: 40.0, elevation: 30.0, perspective: false };
    let o = options(&camera);
    let quant = Quant { density: 3, gradient: 3 };
    let tf = shells();
    let (one_shot, _) =
        boxforge_runtime::render::perm::render(gpu, &d, &vol, Layout::Embedded, &tf, &o, quant, false).unwrap();
    let volume = DeviceVolume::new(gpu, &vol, Layout::Embedded).unwrap();
    let mut renderer = PermRenderer::new(gpu, &d, &volume, &tf, look(&o), quant, false).unwrap();
    let frame = host_frame(gpu, |enc, t| renderer.encode(enc, t, &camera));
    check("PERM", &frame, &one_shot.rgba);
    // The cache's image through a DVR scene (the bench's path) is the same.
    let scene = DvrScene::new(gpu, &d, &vol, Layout::Embedded, o.block).unwrap();
    let table = tf.table();
    let pi = table.preintegrate(o.step as f64);
    let bench = renderer.cache().render(&scene, &table, Some(&pi), &o).unwrap();
    assert_eq!(rms(&bench.rgba, &one_shot.rgba), 0.0, "PERM through a DvrScene");
}

#[test]
fn a_projected_tetrahedra_frame_in_a_host_target_is_the_one_shot_image() {
    let gpu = crate::common::gpu();
    let d = derive("bcc_linear");
    let vol = LatticeVolume::marschner_lobb(&d.filter.lattice, [16, 16, 16]).unwrap();
    let camera = Camera { azimuth: -120.0, elevation: -40.0, perspective: false };
    let o = options(&camera);
    let tf = shells();
    let (one_shot, stats) =
        boxforge_runtime::render::pt::render::render(gpu, &d, &vol, &tf, &o, Shading::Phong, Normals::Vertex).unwrap();
    let options = PtOptions { step: o.step, shading: Shading::Phong, normals: Normals::Vertex };
    let mut renderer = PtRenderer::new(gpu, &d, &vol, &tf, options).unwrap();
    assert_eq!((renderer.drawn(), renderer.total()), (stats.drawn, stats.total));
    assert!(stats.drawn > 0 && stats.drawn < stats.total, "the masks leave out some tetrahedra");
    let frame = host_frame(gpu, |enc, t| renderer.encode(enc, t, &camera));
    check("projected tetrahedra", &frame, &one_shot.rgba);
    // A surface's format: the sRGB target stores the image's bytes.
    let srgb = host_frame_in(gpu, wgpu::TextureFormat::Bgra8UnormSrgb, |enc, t| renderer.encode(enc, t, &camera));
    check("projected tetrahedra, Bgra8UnormSrgb", &srgb, &one_shot.rgba);
    // Perspective is refused by type, not drawn wrong.
    let perspective = Camera { perspective: true, ..camera };
    let texture = target(gpu);
    let view = texture.create_view(&Default::default());
    let mut enc = gpu.device.create_command_encoder(&Default::default());
    let t = Target { view: &view, format: FORMAT, width: SIZE, height: SIZE };
    assert!(matches!(renderer.encode(&mut enc, &t, &perspective), Err(RenderError::PtPerspective)));
}

#[test]
fn a_scheme_frame_in_a_host_target_is_the_one_shot_image() {
    let gpu = crate::common::gpu();
    let base = schemes::base().unwrap();
    let vol = LatticeVolume::marschner_lobb(&base.filter.lattice, [16, 16, 16]).unwrap();
    let tf = shells();
    let volume = DeviceVolume::new(gpu, &vol, Layout::Embedded).unwrap();
    let scheme = Scheme::BilinearSpatial;
    let first = Camera { azimuth: 30.0, elevation: 25.0, perspective: false };
    let mut renderer = SchemeRenderer::new(gpu, &volume, scheme, &tf, look(&options(&first))).unwrap();
    // Looking down z: the renderer compiles the z stack for this frame.
    let camera = Camera { azimuth: 20.0, elevation: 80.0, perspective: false };
    assert_eq!(SchemeRenderer::stack(&camera), 2);
    let o = options(&camera);
    let (one_shot, choice) = schemes::render(gpu, &vol, scheme, &tf, &o).unwrap();
    assert!(choice.contains("plane stack along z"), "{choice}");
    let frame = host_frame(gpu, |enc, t| renderer.encode(enc, t, &camera));
    check("mattausch_bilinear_spatial", &frame, &one_shot.rgba);
    // The one-shot image is the DvrScene's of the z stack, exactly.
    let scene = schemes::scene(gpu, &base, &vol, scheme, 2, o.block).unwrap().render(&tf, &o).unwrap();
    assert_eq!(rms(&scene.rgba, &one_shot.rgba), 0.0);
    // Another lattice is refused by type.
    let cc =
        LatticeVolume::marschner_lobb(&boxforge::spec::lattice::Lattice::builtin("cc").unwrap(), [8, 8, 8]).unwrap();
    let cc = DeviceVolume::new(gpu, &cc, Layout::Embedded).unwrap();
    assert!(matches!(SchemeRenderer::new(gpu, &cc, scheme, &tf, look(&o)), Err(RenderError::SchemeLattice { .. })));
}

/// wgpu's live-object counts on `device`.
fn counts(device: &wgpu::Device) -> Vec<(&'static str, isize)> {
    let c = device.get_internal_counters().hal;
    vec![
        ("buffers", c.buffers.read()),
        ("buffer memory", c.buffer_memory.read()),
        ("textures", c.textures.read()),
        ("texture views", c.texture_views.read()),
        ("bind groups", c.bind_groups.read()),
        ("bind group layouts", c.bind_group_layouts.read()),
        ("pipeline layouts", c.pipeline_layouts.read()),
        ("compute pipelines", c.compute_pipelines.read()),
        ("render pipelines", c.render_pipelines.read()),
        ("shader modules", c.shader_modules.read()),
    ]
}

/// Orbit cameras around the volume, each looking mostly along the axis of
/// its index modulo 3 (x, y, z: the schemes' three stacks).
fn orbit(k: usize) -> Camera {
    let step = k as f32 * 7.0;
    match k % 3 {
        0 => Camera { azimuth: 20.0 + step, elevation: 15.0, perspective: false },
        1 => Camera { azimuth: 100.0 + step, elevation: -20.0, perspective: false },
        _ => Camera { azimuth: step, elevation: 70.0 + k as f32, perspective: false },
    }
}

#[test]
fn frames_after_the_first_create_nothing_while_the_camera_moves() {
    // A device of this test's own: the counters are the device's.
    let gpu = Gpu::new(None).unwrap_or_else(|e| panic!("{e}"));
    let gpu = &gpu;
    let tf = shells();
    let o = options(&Camera::default());
    let bcc = derive("bcc_linear");
    let vol = LatticeVolume::marschner_lobb(&bcc.filter.lattice, [12, 12, 12]).unwrap();
    let volume = DeviceVolume::new(gpu, &vol, Layout::Embedded).unwrap();
    let texture = target(gpu);
    let view = texture.create_view(&Default::default());
    let t = Target { view: &view, format: FORMAT, width: SIZE, height: SIZE };
    let pt = PtOptions { step: o.step, shading: Shading::Phong, normals: Normals::Vertex };
    type Encode<'a> = Box<dyn FnMut(&mut wgpu::CommandEncoder, &Camera) -> Result<(), RenderError> + 'a>;
    // (what, frames before frame 2 is counted: one; a scheme one per plane
    // stack, each compiling its module; buffer writes of a new camera: the
    // parameters, and for projected tetrahedra the back-to-front order)
    let renderers: Vec<(&str, usize, isize, Encode)> = vec![
        ("PERM", 1, 1, {
            let mut r =
                PermRenderer::new(gpu, &bcc, &volume, &tf, look(&o), Quant { density: 2, gradient: 2 }, true).unwrap();
            Box::new(move |enc, c| r.encode(enc, &t, c))
        }),
        ("projected tetrahedra", 1, 2, {
            let mut r = PtRenderer::new(gpu, &bcc, &vol, &tf, pt).unwrap();
            Box::new(move |enc, c| r.encode(enc, &t, c))
        }),
        ("scheme", 3, 1, {
            let mut r = SchemeRenderer::new(gpu, &volume, Scheme::Bilinear, &tf, look(&o)).unwrap();
            Box::new(move |enc, c| r.encode(enc, &t, c))
        }),
    ];
    // One frame, submitted and waited for; the counts while it was
    // recorded (what it created is alive until then) less those before it.
    let frame = |encode: &mut Encode, camera: &Camera| {
        let before = counts(&gpu.device);
        let mut enc = gpu.device.create_command_encoder(&Default::default());
        encode(&mut enc, camera).unwrap();
        let during = counts(&gpu.device);
        gpu.queue.submit([enc.finish()]);
        gpu.wait().unwrap();
        before.iter().zip(during).map(|((name, b), (_, d))| (*name, d - b)).collect::<Vec<_>>()
    };
    for (what, first, writes, mut encode) in renderers {
        for k in 0..first {
            frame(&mut encode, &orbit(k));
        }
        // Frame 2 (after the first along each stack), then 3 to 10, each camera another.
        frame(&mut encode, &orbit(first));
        let after_2 = counts(&gpu.device);
        assert!(after_2[0].1 > 0, "wgpu's counters are off (the `counters` feature)");
        for k in first + 1..first + 9 {
            // Nothing is created even for the frame's life, but the staging
            // buffers of queue.write_buffer (one per write, dropped once done).
            for (name, created) in frame(&mut encode, &orbit(k)) {
                match name {
                    "buffers" => {
                        assert!(created <= writes, "{what}: the frame of orbit camera {k} made {created} buffers")
                    }
                    "buffer memory" => {}
                    _ => assert_eq!(created, 0, "{what}: the frame of orbit camera {k} made {created} {name}"),
                }
            }
        }
        let after_10 = counts(&gpu.device);
        eprintln!("{what}: live objects after frame 2 and frame 10: {after_10:?}");
        assert_eq!(after_2, after_10, "{what}: live objects after frame 2 vs frame 10, the camera moving");
        // The same camera again writes nothing and creates nothing.
        let created = frame(&mut encode, &orbit(first + 8));
        assert!(created.iter().all(|(_, n)| *n == 0), "{what}: a frame of the same camera made {created:?}");
    }
}
