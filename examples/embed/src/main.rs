//! Renders bcc7 on Marschner-Lobb with boxforge inside this program's own
//! wgpu device and writes the frame: `boxforge-embed [out.png] [size]`.

use boxforge_embed::{host_device, read_rgba, texture, Scene};
use boxforge_runtime::render::Camera;

fn main() {
    let mut args = std::env::args().skip(1);
    let out = args.next().unwrap_or_else(|| "embed.png".into());
    let size: u32 = args.next().map_or(Ok(256), |s| s.parse()).unwrap_or_else(|_| {
        eprintln!("error: the size must be a whole number of pixels, e.g. 256");
        std::process::exit(2)
    });
    let run = || -> Result<(), String> {
        let (device, queue) = host_device()?;
        let target = texture(&device, size, wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::COPY_SRC);
        let view = target.create_view(&Default::default());
        let mut scene = Scene::new(device.clone(), queue.clone())?;
        scene.frame(&view, size, &Camera::default(), false)?;
        let rgba = read_rgba(&device, &queue, &target, size);
        let file = std::fs::File::create(&out).map_err(|e| format!("cannot write {out}: {e}"))?;
        let mut enc = png::Encoder::new(std::io::BufWriter::new(file), size, size);
        enc.set_color(png::ColorType::Rgba);
        enc.write_header().and_then(|mut w| w.write_image_data(&rgba)).map_err(|e| e.to_string())?;
        eprintln!("wrote {out}");
        Ok(())
    };
    if let Err(e) = run() {
        eprintln!("error: {e}");
        std::process::exit(2);
    }
}
