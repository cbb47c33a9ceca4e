//! A host program's view of boxforge: it owns the wgpu device, hands it to
//! boxforge once, builds a renderer once and asks it for frames, each
//! recorded into the host's own command encoder and drawn into the host's
//! own colour target (here a `Bgra8UnormSrgb` texture with only
//! `RENDER_ATTACHMENT` usage, what a window surface gives).
//!
//! `main.rs` writes the frame as a PNG; `tests/embed.rs` checks it against
//! `boxforge render`'s image and that later frames create no GPU objects.

use boxforge::derive::Derivation;
use boxforge_runtime::gpu::Gpu;
use boxforge_runtime::render::dvr::transfer::TransferFunction;
use boxforge_runtime::render::{Camera, DvrLook, DvrRenderer, HostDepth, IsoOptions, IsoRenderer, Target};
use boxforge_runtime::volume::{DeviceVolume, LatticeVolume};

/// The host's colour format: a window surface's usual one.
pub const FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Bgra8UnormSrgb;

/// A device as a host program opens it: its own instance and adapter,
/// default limits and no optional features.
pub fn host_device() -> Result<(wgpu::Device, wgpu::Queue), String> {
    let instance = wgpu::Instance::new(wgpu::InstanceDescriptor {
        backends: wgpu::Backends::VULKAN,
        ..wgpu::InstanceDescriptor::new_without_display_handle()
    });
    let adapter =
        pollster::block_on(instance.request_adapter(&wgpu::RequestAdapterOptions::default())).map_err(|e| {
            format!("no Vulkan adapter ({e}): install one, e.g. sudo apt-get install -y mesa-vulkan-drivers")
        })?;
    pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
        label: Some("host"),
        required_features: wgpu::Features::empty(),
        required_limits: wgpu::Limits::default(),
        ..Default::default()
    }))
    .map_err(|e| e.to_string())
}

/// The host's scene: bcc7 on Marschner-Lobb at 41^3 lattice points, as
/// `boxforge render --filter bcc7 --volume ml:41` builds it.
pub struct Scene {
    pub gpu: Gpu,
    pub renderer: IsoRenderer,
    /// The same volume rendered directly, through the `marschner-lobb`
    /// transfer function (sharing the uploaded samples).
    pub dvr: DvrRenderer,
}

impl Scene {
    /// Everything built once: the device handed over, the volume uploaded,
    /// the renderer's shader compiled and its block grid computed.
    pub fn new(device: wgpu::Device, queue: wgpu::Queue) -> Result<Scene, String> {
        let gpu = Gpu::from_device(device, queue);
        let filter = boxforge::spec::catalog::get("bcc7").map_err(|e| e.to_string())?;
        let d = Derivation::new(&filter).map_err(|e| e.to_string())?;
        // `ml:41`: about 41^3 samples on the filter's lattice.
        let edge = boxforge_runtime::scene::matched_edge(&d.filter.lattice, 41f64.powi(3));
        let samples =
            LatticeVolume::marschner_lobb(&d.filter.lattice, [edge, edge, edge]).map_err(|e| e.to_string())?;
        let volume = DeviceVolume::new(&gpu, &samples, boxforge::emit::Layout::Embedded).map_err(|e| e.to_string())?;
        let renderer = IsoRenderer::new(&gpu, &d, &volume, IsoOptions::default()).map_err(|e| e.to_string())?;
        let tf = TransferFunction::preset("marschner-lobb");
        let dvr = DvrRenderer::new(&gpu, &d, &volume, &tf, DvrLook::default()).map_err(|e| e.to_string())?;
        Ok(Scene { gpu, renderer, dvr })
    }

    /// One frame into `view` (a `size` x `size` texture of [`FORMAT`]), in
    /// the host's encoder, submitted by the host: the isosurface, or with
    /// `direct` the volume rendering.
    pub fn frame(&mut self, view: &wgpu::TextureView, size: u32, camera: &Camera, direct: bool) -> Result<(), String> {
        let mut encoder =
            self.gpu.device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("frame") });
        let target = Target { view, format: FORMAT, width: size, height: size };
        if direct {
            self.dvr.encode(&mut encoder, &target, camera).map_err(|e| e.to_string())?;
        } else {
            self.renderer.encode(&mut encoder, &target, camera).map_err(|e| e.to_string())?;
        }
        self.gpu.queue.submit([encoder.finish()]);
        Ok(())
    }
}

impl Scene {
    /// The isosurface frame over the host's own pass: the target cleared to
    /// `clear` (linear, as wgpu takes clear colours) and a depth texture
    /// (`Depth32Float`, `TEXTURE_BINDING`) cleared to the far plane, which
    /// a host's opaque geometry would have written; the rays stop at it
    /// and the surface is drawn over the host's colour.
    pub fn frame_over_host(
        &mut self,
        view: &wgpu::TextureView,
        size: u32,
        camera: &Camera,
        clear: wgpu::Color,
    ) -> Result<(), String> {
        let device = &self.gpu.device;
        let depth = device.create_texture(&wgpu::TextureDescriptor {
            label: Some("host depth"),
            size: wgpu::Extent3d { width: size, height: size, depth_or_array_layers: 1 },
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format: wgpu::TextureFormat::Depth32Float,
            usage: wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::TEXTURE_BINDING,
            view_formats: &[],
        });
        let depth_view = depth.create_view(&Default::default());
        let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("host pass") });
        // The host's opaque pass (nothing drawn here but the clears).
        drop(encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("host pass"),
            color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                view,
                depth_slice: None,
                resolve_target: None,
                ops: wgpu::Operations { load: wgpu::LoadOp::Clear(clear), store: wgpu::StoreOp::Store },
            })],
            depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                view: &depth_view,
                depth_ops: Some(wgpu::Operations { load: wgpu::LoadOp::Clear(1.0), store: wgpu::StoreOp::Store }),
                stencil_ops: None,
            }),
            timestamp_writes: None,
            occlusion_query_set: None,
            multiview_mask: None,
        }));
        let target = Target { view, format: FORMAT, width: size, height: size };
        self.renderer
            .encode_with_depth(&mut encoder, &target, (*camera).into(), Some(HostDepth { view: &depth_view }))
            .map_err(|e| e.to_string())?;
        self.gpu.queue.submit([encoder.finish()]);
        Ok(())
    }
}

/// A host texture of [`FORMAT`] with `usage`.
pub fn texture(device: &wgpu::Device, size: u32, usage: wgpu::TextureUsages) -> wgpu::Texture {
    device.create_texture(&wgpu::TextureDescriptor {
        label: Some("host target"),
        size: wgpu::Extent3d { width: size, height: size, depth_or_array_layers: 1 },
        mip_level_count: 1,
        sample_count: 1,
        dimension: wgpu::TextureDimension::D2,
        format: FORMAT,
        usage,
        view_formats: &[],
    })
}

/// The texture's pixels as RGBA8 rows from the top (the host's own readback;
/// the texture needs `COPY_SRC`).
pub fn read_rgba(device: &wgpu::Device, queue: &wgpu::Queue, texture: &wgpu::Texture, size: u32) -> Vec<u8> {
    let row = (size * 4).div_ceil(wgpu::COPY_BYTES_PER_ROW_ALIGNMENT) * wgpu::COPY_BYTES_PER_ROW_ALIGNMENT;
    let buffer = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("host readback"),
        size: (row * size) as u64,
        usage: wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::MAP_READ,
        mapped_at_creation: false,
    });
    let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("readback") });
    encoder.copy_texture_to_buffer(
        texture.as_image_copy(),
        wgpu::TexelCopyBufferInfo {
            buffer: &buffer,
            layout: wgpu::TexelCopyBufferLayout { offset: 0, bytes_per_row: Some(row), rows_per_image: Some(size) },
        },
        wgpu::Extent3d { width: size, height: size, depth_or_array_layers: 1 },
    );
    queue.submit([encoder.finish()]);
    buffer.slice(..).map_async(wgpu::MapMode::Read, |r| r.expect("map the readback"));
    device.poll(wgpu::PollType::wait_indefinitely()).expect("poll");
    let data = buffer.slice(..).get_mapped_range().expect("mapped").to_vec();
    // BGRA rows (padded) to RGBA rows.
    let mut rgba = Vec::with_capacity((size * size * 4) as usize);
    for y in 0..size as usize {
        for px in data[y * row as usize..][..size as usize * 4].chunks(4) {
            rgba.extend_from_slice(&[px[2], px[1], px[0], px[3]]);
        }
    }
    rgba
}
