//! The embedding targets: boxforge renders in a host's device (default
//! limits, no optional features) into a render-attachment-only
//! `Bgra8UnormSrgb` target; the frame equals `boxforge render`'s image; and
//! frames after the first create no buffer, texture or shader module.

use boxforge_embed::{host_device, read_rgba, texture, Scene, FORMAT};
use boxforge_runtime::render::Camera;
use std::path::PathBuf;

const SIZE: u32 = 160;

/// A view from above, where the surface covers a good part of the frame.
fn camera() -> Camera {
    Camera { azimuth: 30.0, elevation: 60.0, perspective: false }
}
/// The ray caster's background (a miss).
const MISS: [u8; 3] = [20, 20, 26];

/// The `boxforge` binary of this build (the test command builds it with the
/// workspace's tests).
fn boxforge_bin() -> PathBuf {
    let exe = std::env::current_exe().unwrap();
    let dir = exe.parent().and_then(|d| d.parent()).expect("target/<profile>/deps");
    let bin = dir.join(format!("boxforge{}", std::env::consts::EXE_SUFFIX));
    assert!(bin.exists(), "{} is missing: build it with cargo build -p boxforge-runtime", bin.display());
    bin
}

fn read_png(path: &std::path::Path) -> Vec<u8> {
    let mut reader =
        png::Decoder::new(std::io::BufReader::new(std::fs::File::open(path).unwrap())).read_info().unwrap();
    let mut buf = vec![0; reader.output_buffer_size().unwrap()];
    let info = reader.next_frame(&mut buf).unwrap();
    assert_eq!((info.width, info.height, info.color_type), (SIZE, SIZE, png::ColorType::Rgba));
    buf
}

/// Runs `boxforge render` with `args` at SIZE and the test's view; its image.
fn cli_image(args: &[&str]) -> Vec<u8> {
    let dir = std::env::temp_dir().join(format!("boxforge-embed-{}-{}", std::process::id(), args.len()));
    std::fs::create_dir_all(&dir).unwrap();
    let png = dir.join("cli.png");
    let size = SIZE.to_string();
    let out = std::process::Command::new(boxforge_bin())
        .args(["render", "--filter", "bcc7", "--volume", "ml:41", "--view", "30,60", "--size", &size])
        .args(args)
        .arg("--out")
        .arg(&png)
        .output()
        .unwrap();
    assert!(out.status.success(), "boxforge render failed: {}", String::from_utf8_lossy(&out.stderr));
    let image = read_png(&png);
    let _ = std::fs::remove_dir_all(&dir);
    image
}

fn rms(a: &[u8], b: &[u8]) -> f64 {
    let sq: f64 = a.iter().zip(b).map(|(&x, &y)| (x as f64 - y as f64).powi(2)).sum();
    (sq / a.len() as f64).sqrt()
}

#[test]
fn a_host_device_renders_boxforge_renders_images_into_a_surface_like_target() {
    let (device, queue) = host_device().unwrap_or_else(|e| panic!("{e}"));
    let mut scene = Scene::new(device.clone(), queue.clone()).unwrap_or_else(|e| panic!("{e}"));
    let readable = texture(&device, SIZE, wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::COPY_SRC);
    // What a window surface gives: render attachment, nothing else. Any use
    // beyond that is a validation error, caught here.
    let surface_like = texture(&device, SIZE, wgpu::TextureUsages::RENDER_ATTACHMENT);
    for (direct, cli_args) in
        [(false, &["--iso", "0.5"][..]), (true, &["--mode", "dvr", "--tf", "marschner-lobb", "--step", "0.5"][..])]
    {
        let scope = device.push_error_scope(wgpu::ErrorFilter::Validation);
        scene.frame(&surface_like.create_view(&Default::default()), SIZE, &camera(), direct).unwrap();
        device.poll(wgpu::PollType::wait_indefinitely()).unwrap();
        assert!(pollster::block_on(scope.pop()).is_none(), "the renderer used the target beyond RENDER_ATTACHMENT");
        // The same frame into a target the host can read back.
        scene.frame(&readable.create_view(&Default::default()), SIZE, &camera(), direct).unwrap();
        let ours = read_rgba(&device, &queue, &readable, SIZE);
        let cli = cli_image(cli_args);
        let pixels = (SIZE * SIZE) as usize;
        let shown = ours.chunks(4).filter(|p| p[..3] != MISS).count();
        let rms = rms(&ours, &cli);
        let what = if direct { "volume rendering" } else { "isosurface" };
        eprintln!(
            "{what}, {FORMAT:?} target vs boxforge render: RMS {rms:.3}/255, {shown} of {pixels} pixels not background"
        );
        assert!(shown * 5 >= pixels, "{what}: only {shown} of {pixels} pixels show the volume");
        assert!(rms < 0.5, "{what}: RMS {rms}/255 against boxforge render");
    }
}

#[test]
fn over_a_host_pass_with_nothing_drawn_the_frame_is_the_same() {
    // A host depth at the far plane stops no ray: over the host's colour
    // cleared to the ray caster's background the frame is the plain one
    // (hits opaque, misses transparent over the clear).
    let (device, queue) = host_device().unwrap_or_else(|e| panic!("{e}"));
    let mut scene = Scene::new(device.clone(), queue.clone()).unwrap_or_else(|e| panic!("{e}"));
    let readable = texture(&device, SIZE, wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::COPY_SRC);
    let view = readable.create_view(&Default::default());
    scene.frame(&view, SIZE, &camera(), false).unwrap();
    let plain = read_rgba(&device, &queue, &readable, SIZE);
    // The background's sRGB bytes, decoded (the target is sRGB).
    let linear = |b: u8| {
        let c = b as f64 / 255.0;
        if c <= 0.04045 {
            c / 12.92
        } else {
            ((c + 0.055) / 1.055).powf(2.4)
        }
    };
    let clear = wgpu::Color { r: linear(MISS[0]), g: linear(MISS[1]), b: linear(MISS[2]), a: 1.0 };
    scene.frame_over_host(&view, SIZE, &camera(), clear).unwrap();
    let over = read_rgba(&device, &queue, &readable, SIZE);
    let differ = plain.iter().zip(&over).filter(|(a, b)| a != b).count();
    assert!(plain.chunks(4).filter(|p| p[..3] != MISS).count() * 5 >= (SIZE * SIZE) as usize);
    assert_eq!(differ, 0, "{differ} bytes differ from the frame without a host depth");
}

#[test]
fn frames_after_the_first_create_no_buffer_texture_or_shader_module() {
    let (device, queue) = host_device().unwrap_or_else(|e| panic!("{e}"));
    let mut scene = Scene::new(device.clone(), queue.clone()).unwrap_or_else(|e| panic!("{e}"));
    let target = texture(&device, SIZE, wgpu::TextureUsages::RENDER_ATTACHMENT);
    let view = target.create_view(&Default::default());
    let camera = camera();
    let counts = |device: &wgpu::Device| {
        let c = device.get_internal_counters().hal;
        [
            ("buffers", c.buffers.read()),
            ("textures", c.textures.read()),
            ("texture views", c.texture_views.read()),
            ("shader modules", c.shader_modules.read()),
            ("bind groups", c.bind_groups.read()),
            ("buffer memory", c.buffer_memory.read()),
        ]
    };
    for direct in [false, true] {
        scene.frame(&view, SIZE, &camera, direct).unwrap();
        device.poll(wgpu::PollType::wait_indefinitely()).unwrap();
        // Frames 2 to 10 in one encoder: anything a frame created would stay
        // alive (referenced by the encoder) until the submit, so the live
        // counts after frame 10 would exceed those after frame 2.
        let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("frames") });
        let t = boxforge_runtime::render::Target { view: &view, format: FORMAT, width: SIZE, height: SIZE };
        let mut frame = |encoder: &mut wgpu::CommandEncoder| {
            if direct {
                scene.dvr.encode(encoder, &t, &camera).unwrap()
            } else {
                scene.renderer.encode(encoder, &t, &camera).unwrap()
            }
        };
        frame(&mut encoder);
        let after_2 = counts(&device);
        assert!(after_2[0].1 > 0, "wgpu's counters are off (the `counters` feature)");
        for _ in 3..=10 {
            frame(&mut encoder);
        }
        let after_10 = counts(&device);
        queue.submit([encoder.finish()]);
        device.poll(wgpu::PollType::wait_indefinitely()).unwrap();
        assert_eq!(after_2, after_10, "live objects after frame 2 vs frame 10 (direct: {direct})");
        // A new camera writes the parameters (a buffer write) and creates
        // nothing that outlives the frame.
        let before = counts(&device);
        scene.frame(&view, SIZE, &Camera { azimuth: 120.0, ..camera }, direct).unwrap();
        device.poll(wgpu::PollType::wait_indefinitely()).unwrap();
        assert_eq!(before, counts(&device), "live objects around a frame with a new camera (direct: {direct})");
    }
}
