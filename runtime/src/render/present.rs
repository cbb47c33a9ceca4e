//! Draws a ray caster's image (one RGBA8 word per pixel in a storage buffer)
//! into a host's colour target with a full-screen triangle: the last step of
//! every renderer's `encode`. The image holds display (sRGB) bytes; into an
//! sRGB target they are decoded to linear, so that the target stores the
//! same bytes the PNG of `boxforge render` holds. A frame with a host depth
//! is drawn over the target's contents instead (premultiplied colour and
//! alpha, blended One / OneMinusSrcAlpha; into sRGB targets the hardware
//! blends the decoded values, so a translucent pixel is close to, not
//! exactly, the blend of the display bytes).

use crate::gpu::{Gpu, GpuError};
use crate::render::RenderError;
use std::collections::HashMap;

const SHADER: &str = r#"
struct PresentParams {
    width: u32,
    srgb: u32,
}
@group(0) @binding(0) var<storage, read> image: array<u32>;
@group(0) @binding(1) var<uniform> params: PresentParams;

@vertex
fn present_vs(@builtin(vertex_index) i: u32) -> @builtin(position) vec4<f32> {
    let x = f32((i << 1u) & 2u);
    let y = f32(i & 2u);
    return vec4<f32>(x * 2.0 - 1.0, 1.0 - y * 2.0, 0.0, 1.0);
}

fn to_linear(c: vec3<f32>) -> vec3<f32> {
    return select(pow((c + 0.055) / 1.055, vec3<f32>(2.4)), c / 12.92, c <= vec3<f32>(0.04045));
}

@fragment
fn present_fs(@builtin(position) pos: vec4<f32>) -> @location(0) vec4<f32> {
    let p = vec2<u32>(pos.xy);
    let c = unpack4x8unorm(image[p.y * params.width + p.x]);
    return vec4<f32>(select(c.rgb, to_linear(c.rgb), params.srgb != 0u), c.a);
}
"#;

/// The present pipeline, one per target format and blending (opaque, or
/// over the target's contents), built on first use.
pub struct Presenter {
    shader: wgpu::ShaderModule,
    layout: wgpu::BindGroupLayout,
    pipeline_layout: wgpu::PipelineLayout,
    pipelines: HashMap<(wgpu::TextureFormat, bool), wgpu::RenderPipeline>,
}

impl Presenter {
    pub fn new(gpu: &Gpu) -> Result<Presenter, GpuError> {
        let shader = gpu.compile("present.wgsl", SHADER)?;
        let entry = |binding, ty| wgpu::BindGroupLayoutEntry {
            binding,
            visibility: wgpu::ShaderStages::FRAGMENT,
            ty: wgpu::BindingType::Buffer { ty, has_dynamic_offset: false, min_binding_size: None },
            count: None,
        };
        let layout = gpu.device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("present"),
            entries: &[
                entry(0, wgpu::BufferBindingType::Storage { read_only: true }),
                entry(1, wgpu::BufferBindingType::Uniform),
            ],
        });
        let pipeline_layout = gpu.device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("present"),
            bind_group_layouts: &[Some(&layout)],
            immediate_size: 0,
        });
        Ok(Presenter { shader, layout, pipeline_layout, pipelines: HashMap::new() })
    }

    /// A bind group that presents `image` (one word per pixel, rows of `width`).
    pub fn bind(&self, gpu: &Gpu, image: &wgpu::Buffer, width: u32, format: wgpu::TextureFormat) -> wgpu::BindGroup {
        let params = gpu.uniform_buffer("present params", bytemuck::cast_slice(&[width, format.is_srgb() as u32]));
        gpu.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("present"),
            layout: &self.layout,
            entries: &[
                wgpu::BindGroupEntry { binding: 0, resource: image.as_entire_binding() },
                wgpu::BindGroupEntry { binding: 1, resource: params.as_entire_binding() },
            ],
        })
    }

    /// Makes sure the pipeline for `format` exists (outside any pass).
    pub fn prepare(&mut self, gpu: &Gpu, format: wgpu::TextureFormat) -> Result<(), GpuError> {
        self.prepare_blend(gpu, format, false)
    }

    /// [`Presenter::prepare`] for drawing opaque (`over` false) or with
    /// premultiplied alpha over the target's contents.
    pub fn prepare_blend(&mut self, gpu: &Gpu, format: wgpu::TextureFormat, over: bool) -> Result<(), GpuError> {
        if self.pipelines.contains_key(&(format, over)) {
            return Ok(());
        }
        let pipeline = gpu.checked(&format!("present pipeline for {format:?}"), || {
            gpu.device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
                label: Some("present"),
                layout: Some(&self.pipeline_layout),
                vertex: wgpu::VertexState {
                    module: &self.shader,
                    entry_point: Some("present_vs"),
                    compilation_options: Default::default(),
                    buffers: &[],
                },
                fragment: Some(wgpu::FragmentState {
                    module: &self.shader,
                    entry_point: Some("present_fs"),
                    compilation_options: Default::default(),
                    targets: &[Some(wgpu::ColorTargetState {
                        format,
                        blend: over.then_some(wgpu::BlendState::PREMULTIPLIED_ALPHA_BLENDING),
                        write_mask: wgpu::ColorWrites::ALL,
                    })],
                }),
                primitive: wgpu::PrimitiveState::default(),
                depth_stencil: None,
                multisample: wgpu::MultisampleState::default(),
                multiview_mask: None,
                cache: None,
            })
        })?;
        self.pipelines.insert((format, over), pipeline);
        Ok(())
    }

    /// Records the draw of `bind`'s image into `view` (after [`Presenter::prepare`]).
    pub fn encode(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        view: &wgpu::TextureView,
        format: wgpu::TextureFormat,
        bind: &wgpu::BindGroup,
    ) {
        self.encode_blend(encoder, view, format, bind, false)
    }

    /// [`Presenter::encode`], opaque over a cleared target (`over` false) or
    /// with premultiplied alpha over its contents (after
    /// [`Presenter::prepare_blend`] with the same `over`).
    pub fn encode_blend(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        view: &wgpu::TextureView,
        format: wgpu::TextureFormat,
        bind: &wgpu::BindGroup,
        over: bool,
    ) {
        let Some(pipeline) = self.pipelines.get(&(format, over)) else { return };
        let load = if over { wgpu::LoadOp::Load } else { wgpu::LoadOp::Clear(wgpu::Color::BLACK) };
        let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("present"),
            color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                view,
                depth_slice: None,
                resolve_target: None,
                ops: wgpu::Operations { load, store: wgpu::StoreOp::Store },
            })],
            depth_stencil_attachment: None,
            timestamp_writes: None,
            occlusion_query_set: None,
            multiview_mask: None,
        });
        pass.set_pipeline(pipeline);
        pass.set_bind_group(0, bind, &[]);
        pass.draw(0..3, 0..1);
    }
}

/// A ray caster's image for one frame size: the buffer its compute pass
/// writes (one RGBA8 word per pixel), the caster's group-1 bind group over
/// it, and the present bind group for the last target format. Every
/// per-frame renderer keeps one and rebuilds it only when the size changes.
pub(crate) struct FrameImage {
    pub width: u32,
    pub height: u32,
    pub image: wgpu::Buffer,
    pub caster: wgpu::BindGroup,
    present: Option<(wgpu::TextureFormat, wgpu::BindGroup)>,
}

impl FrameImage {
    pub(crate) fn new(width: u32, height: u32, image: wgpu::Buffer, caster: wgpu::BindGroup) -> FrameImage {
        FrameImage { width, height, image, caster, present: None }
    }

    /// Records the ray caster (`pipeline`, the samples at group 0, this
    /// image's caster group at 1; 8x8 workgroups over the image) and the
    /// draw of the image into `view` of `format`.
    #[allow(dead_code)] // the opaque frame of renderers without a host depth (PERM, PT, schemes)
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn encode(
        &mut self,
        gpu: &Gpu,
        presenter: &mut Presenter,
        encoder: &mut wgpu::CommandEncoder,
        (label, pipeline, samples): (&str, &wgpu::ComputePipeline, &wgpu::BindGroup),
        view: &wgpu::TextureView,
        format: wgpu::TextureFormat,
    ) -> Result<(), GpuError> {
        self.encode_over(gpu, presenter, encoder, (label, pipeline, samples), view, format, false)
    }

    /// [`FrameImage::encode`], the image drawn opaque (`over` false) or with
    /// premultiplied alpha over the target's contents.
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn encode_over(
        &mut self,
        gpu: &Gpu,
        presenter: &mut Presenter,
        encoder: &mut wgpu::CommandEncoder,
        (label, pipeline, samples): (&str, &wgpu::ComputePipeline, &wgpu::BindGroup),
        view: &wgpu::TextureView,
        format: wgpu::TextureFormat,
        over: bool,
    ) -> Result<(), GpuError> {
        presenter.prepare_blend(gpu, format, over)?;
        if self.present.as_ref().map(|(f, _)| *f) != Some(format) {
            self.present = Some((format, presenter.bind(gpu, &self.image, self.width, format)));
        }
        {
            let mut pass =
                encoder.begin_compute_pass(&wgpu::ComputePassDescriptor { label: Some(label), timestamp_writes: None });
            pass.set_pipeline(pipeline);
            pass.set_bind_group(0, samples, &[]);
            pass.set_bind_group(1, &self.caster, &[]);
            pass.dispatch_workgroups(self.width.div_ceil(8), self.height.div_ceil(8), 1);
        }
        let present = &self.present.as_ref().expect("prepared above").1;
        presenter.encode_blend(encoder, view, format, present, over);
        Ok(())
    }
}

/// A zeroed image buffer (one word per pixel) for a `width` x `height`
/// frame, refused past the device's storage-binding limit.
pub(crate) fn image_buffer(gpu: &Gpu, label: &str, width: u32, height: u32) -> Result<wgpu::Buffer, RenderError> {
    let limit = gpu.limits().max_storage_buffer_binding_size;
    let bytes = width as u64 * height as u64 * 4;
    if bytes > limit {
        return Err(RenderError::TargetTooLarge { width, height, limit });
    }
    Ok(gpu.storage_buffer(label, &vec![0u8; bytes as usize], true))
}
