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

#[test]
fn a_host_device_renders_boxforge_renders_image_into_a_surface_like_target() {
    let (device, queue) = host_device().unwrap_or_else(|e| panic!("{e}"));
    let mut scene = Scene::new(device.clone(), queue.clone()).unwrap_or_else(|e| panic!("{e}"));
    // What a window surface gives: render attachment, nothing else. Any use
    // beyond that is a validation error, caught here.
    let surface_like = texture(&device, SIZE, wgpu::TextureUsages::RENDER_ATTACHMENT);
    let scope = device.push_error_scope(wgpu::ErrorFilter::Validation);
    scene.frame(&surface_like.create_view(&Default::default()), SIZE, &camera()).unwrap();
    device.poll(wgpu::PollType::wait_indefinitely()).unwrap();
    assert!(pollster::block_on(scope.pop()).is_none(), "the renderer used the target beyond RENDER_ATTACHMENT");
    // The same frame into a target the host can read back.
    let readable = texture(&device, SIZE, wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::COPY_SRC);
    scene.frame(&readable.create_view(&Default::default()), SIZE, &camera()).unwrap();
    let ours = read_rgba(&device, &queue, &readable, SIZE);

    let dir = std::env::temp_dir().join(format!("boxforge-embed-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let png = dir.join("cli.png");
    let size = SIZE.to_string();
    let out = std::process::Command::new(boxforge_bin())
        .args(["render", "--filter", "bcc7", "--volume", "ml:41", "--iso", "0.5", "--view", "30,60", "--size", &size])
        .arg("--out")
        .arg(&png)
        .output()
        .unwrap();
    assert!(out.status.success(), "boxforge render failed: {}", String::from_utf8_lossy(&out.stderr));
    let cli = read_png(&png);
    let _ = std::fs::remove_dir_all(&dir);

    let pixels = (SIZE * SIZE) as usize;
    let hits = ours.chunks(4).filter(|p| p[..3] != MISS).count();
    assert!(hits * 5 >= pixels, "only {hits} of {pixels} pixels hit the surface");
    let sq: f64 = ours.iter().zip(&cli).map(|(&a, &b)| (a as f64 - b as f64).powi(2)).sum();
    let rms = (sq / ours.len() as f64).sqrt();
    eprintln!("{FORMAT:?} target vs boxforge render: RMS {rms:.3}/255, {hits} of {pixels} pixels on the surface");
    assert!(rms < 0.5, "RMS {rms}/255 against boxforge render");
}

#[test]
fn frames_after_the_first_create_no_buffer_texture_or_shader_module() {
    let (device, queue) = host_device().unwrap_or_else(|e| panic!("{e}"));
    let mut scene = Scene::new(device.clone(), queue.clone()).unwrap_or_else(|e| panic!("{e}"));
    let target = texture(&device, SIZE, wgpu::TextureUsages::RENDER_ATTACHMENT);
    let view = target.create_view(&Default::default());
    let camera = Camera::default();
    scene.frame(&view, SIZE, &camera).unwrap();
    device.poll(wgpu::PollType::wait_indefinitely()).unwrap();
    // Frames 2 to 10 in one encoder: anything a frame created would stay
    // alive (referenced by the encoder) until the submit, so the live
    // counts after frame 10 would exceed those after frame 2.
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
    let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("frames") });
    let target_desc = boxforge_runtime::render::Target { view: &view, format: FORMAT, width: SIZE, height: SIZE };
    scene.renderer.encode(&mut encoder, &target_desc, &camera).unwrap();
    let after_2 = counts(&device);
    assert!(after_2[0].1 > 0, "wgpu's counters are off (the `counters` feature)");
    for _ in 3..=10 {
        scene.renderer.encode(&mut encoder, &target_desc, &camera).unwrap();
    }
    let after_10 = counts(&device);
    queue.submit([encoder.finish()]);
    device.poll(wgpu::PollType::wait_indefinitely()).unwrap();
    assert_eq!(after_2, after_10, "live objects after frame 2 vs frame 10");
    // A new camera writes the ray parameters (a buffer write) and still
    // creates nothing that outlives the frame.
    let before = counts(&device);
    scene.frame(&view, SIZE, &Camera { azimuth: 120.0, ..camera }).unwrap();
    device.poll(wgpu::PollType::wait_indefinitely()).unwrap();
    assert_eq!(before, counts(&device), "live objects before and after a frame with a new camera");
}
