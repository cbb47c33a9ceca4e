//! The projected-tetrahedra renderer a host drives frame by frame: built
//! once (the visibility masks of the transfer function, the render
//! pipeline of `templates/pt.wgsl`, the samples, tetrahedron types and
//! pre-integration table uploaded, the visible tetrahedra's buffer sized),
//! then [`PtRenderer::encode`] records a frame: the back-to-front order of
//! the view, computed on the CPU and written into the existing buffer
//! (only when the view direction changed), one instanced draw into an
//! Rgba16Float image blended "over", then a compute pass that rounds it to
//! the RGBA8 words every renderer presents and the full-screen draw of
//! [`crate::render::present`] into the host's target. The f16 image, not
//! the host's target, takes the blending: a target of 8 bits per channel
//! would round after every tetrahedron. Frames after the first at one size
//! create no buffer, texture or shader module.

use super::data::{packed_data, visibility_masks, Normals, PtParams, Shading};
use super::tets::{inverse_edges, Complexes, Grid};
use crate::gpu::binding::{storage_entry, uniform_entry};
use crate::gpu::Gpu;
use crate::render::camera::{Camera, Target};
use crate::render::dvr::transfer::TransferFunction;
use crate::render::dvr::{BACKGROUND, G0_OF_RANGE, LIGHT};
use crate::render::iso::{ray_params_for, Frame, RenderOptions};
use crate::render::present::{image_buffer, FrameImage, Presenter};
use crate::render::RenderError;
use crate::volume::LatticeVolume;
use boxforge::derive::Derivation;
use std::time::Instant;

/// The pass that rounds the f16 image to RGBA8 words (alpha 255), as
/// WGSL's pack4x8unorm rounds: floor(0.5 + 255 clamp(c, 0, 1)).
const TO_WORDS: &str = r#"
@group(0) @binding(0) var colour: texture_2d<f32>;
@group(1) @binding(0) var<storage, read_write> image: array<u32>;

@compute @workgroup_size(8, 8)
fn pt_words_main(@builtin(global_invocation_id) id: vec3<u32>) {
    let size = textureDimensions(colour);
    if (id.x >= size.x || id.y >= size.y) {
        return;
    }
    let c = textureLoad(colour, vec2<i32>(id.xy), 0);
    image[id.y * size.x + id.x] = pack4x8unorm(vec4<f32>(c.rgb, 1.0));
}
"#;

/// The format the tetrahedra are blended in.
const BLEND_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba16Float;

/// How the tetrahedra look, independent of the frame.
#[derive(Clone, Copy, Debug)]
pub struct PtOptions {
    /// The segment length the pre-integration table is for, in cells.
    pub step: f32,
    pub shading: Shading,
    pub normals: Normals,
}

impl Default for PtOptions {
    fn default() -> Self {
        PtOptions { step: 0.5, shading: Shading::Phong, normals: Normals::Vertex }
    }
}

/// The images of one frame size: the f16 image the tetrahedra blend into
/// and its binding for the rounding pass, and the RGBA8 words presented.
struct Images {
    view: wgpu::TextureView,
    colour: wgpu::BindGroup,
    words: FrameImage,
}

/// Projected tetrahedra of one BCC or CC volume with one transfer function.
pub struct PtRenderer {
    gpu: Gpu,
    complexes: Complexes,
    masks: Vec<u16>,
    radius: usize,
    dims: [usize; 3],
    /// The uniform block with the frame's fields (camera, image size) to fill.
    base: PtParams,
    last_params: Option<PtParams>,
    last_forward: Option<[f64; 3]>,
    drawn: usize,
    total: usize,
    /// CPU time of the masks, and of the last back-to-front order (ms).
    masks_ms: f64,
    sort_ms: f64,
    pipeline: wgpu::RenderPipeline,
    group: wgpu::BindGroup,
    params: wgpu::Buffer,
    ids: wgpu::Buffer,
    words_pipeline: wgpu::ComputePipeline,
    colour_layout: wgpu::BindGroupLayout,
    words_layout: wgpu::BindGroupLayout,
    /// Built by the first frame into a host's target (the one-shot frames need none).
    presenter: Option<Presenter>,
    images: Option<Images>,
}

impl PtRenderer {
    /// The meshes of `vol` (BCC: the Delaunay tetrahedra; CC: six Kuhn
    /// tetrahedra per cube), the tetrahedra `tf` shows, and the pipelines;
    /// `d` is the filter whose valid box clips the segments (the ray
    /// caster's, so both show the same region).
    pub fn new(
        gpu: &Gpu,
        d: &Derivation,
        vol: &LatticeVolume,
        tf: &TransferFunction,
        options: PtOptions,
    ) -> Result<PtRenderer, RenderError> {
        let grid =
            Grid::of(&vol.lattice).ok_or_else(|| RenderError::PtLattice { lattice: vol.lattice.name.clone() })?;
        let started = Instant::now();
        let table = tf.table();
        let pi = table.preintegrate(options.step as f64);
        let complexes = Complexes::cover(grid, vol.dims);
        let masks = visibility_masks(&complexes, vol, &table);
        let masks_ms = started.elapsed().as_secs_f64() * 1e3;
        let drawn: usize = masks.iter().map(|m| m.count_ones() as usize).sum();
        let types = grid.types();
        let total = complexes.len() * types.len();
        let type_words: Vec<[i32; 4]> =
            types.iter().flat_map(|t| t.map(|v| [v[0] as i32, v[1] as i32, v[2] as i32, 0])).collect();
        let inv_words: Vec<[f32; 4]> = types
            .iter()
            .flat_map(|t| inverse_edges(t).map(|row| [row[0] as f32, row[1] as f32, row[2] as f32, 0.0]))
            .collect();
        let span = table.hi - table.lo;
        let base = PtParams {
            camera: bytemuck::Zeroable::zeroed(),
            tf: [table.lo, 0.0, (pi.size as f32 - 1.0) / span, options.step],
            light: [LIGHT[0], LIGHT[1], LIGHT[2], G0_OF_RANGE * span],
            image: [0, 0, (options.shading == Shading::Phong) as i32, (options.normals == Normals::Vertex) as i32],
            dims: [vol.dims[0] as i32, vol.dims[1] as i32, vol.dims[2] as i32, (grid == Grid::Cc) as i32],
            counts: [
                complexes.counts[0] as i32,
                complexes.counts[1] as i32,
                complexes.counts[2] as i32,
                grid.spacing() as i32,
            ],
            origin: [
                complexes.origin[0] as i32,
                complexes.origin[1] as i32,
                complexes.origin[2] as i32,
                pi.size as i32,
            ],
        };
        let data = packed_data(vol, grid);
        let limit = gpu.limits().max_storage_buffer_binding_size.min(gpu.limits().max_buffer_size);
        for (what, bytes) in [("samples", data.len() * 4), ("visible tetrahedra", drawn * 4)] {
            if bytes as u64 > limit {
                return Err(RenderError::PtTooLarge { what, bytes: bytes as u64, limit });
            }
        }

        let dev = &gpu.device;
        let shader = gpu.compile("pt.wgsl", super::SHADER)?;
        let entries: Vec<wgpu::BindGroupLayoutEntry> = (0..6)
            .map(|b| {
                let mut e = if b == 0 { uniform_entry(0) } else { storage_entry(b, true) };
                e.visibility = wgpu::ShaderStages::VERTEX_FRAGMENT;
                e
            })
            .collect();
        let layout =
            dev.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor { label: Some("pt"), entries: &entries });
        let pipeline = draw_pipeline(gpu, &shader, &layout)?;
        let params = gpu.uniform_buffer("pt params", bytemuck::bytes_of(&base));
        let ids = gpu.storage_buffer("pt ids", &vec![0u8; drawn.max(1) * 4], false);
        let buffers = [
            &params,
            &gpu.storage_buffer("pt data", bytemuck::cast_slice(&data), false),
            &gpu.storage_buffer("pt types", bytemuck::cast_slice(&type_words), false),
            &gpu.storage_buffer("pt inverse edges", bytemuck::cast_slice(&inv_words), false),
            &ids,
            &gpu.storage_buffer("pt preint", bytemuck::cast_slice(&pi.entries), false),
        ];
        let bind_entries: Vec<wgpu::BindGroupEntry> = buffers
            .iter()
            .enumerate()
            .map(|(b, buf)| wgpu::BindGroupEntry { binding: b as u32, resource: buf.as_entire_binding() })
            .collect();
        let group = dev.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("pt"),
            layout: &layout,
            entries: &bind_entries,
        });

        let words_shader = gpu.compile("pt_words.wgsl", TO_WORDS)?;
        let colour_layout = dev.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("pt colour"),
            entries: &[wgpu::BindGroupLayoutEntry {
                binding: 0,
                visibility: wgpu::ShaderStages::COMPUTE,
                ty: wgpu::BindingType::Texture {
                    sample_type: wgpu::TextureSampleType::Float { filterable: false },
                    view_dimension: wgpu::TextureViewDimension::D2,
                    multisampled: false,
                },
                count: None,
            }],
        });
        let words_layout = dev.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("pt words"),
            entries: &[storage_entry(0, false)],
        });
        let words_pipeline =
            gpu.pipeline("pt words", &words_shader, &[&colour_layout, &words_layout], "pt_words_main")?;
        Ok(PtRenderer {
            gpu: gpu.clone(),
            complexes,
            masks,
            radius: crate::volume::support_radius(d),
            dims: vol.dims,
            base,
            last_params: None,
            last_forward: None,
            drawn,
            total,
            masks_ms,
            sort_ms: 0.0,
            pipeline,
            group,
            params,
            ids,
            words_pipeline,
            colour_layout,
            words_layout,
            presenter: None,
            images: None,
        })
    }

    /// Tetrahedra drawn per frame (those the transfer function shows).
    pub fn drawn(&self) -> usize {
        self.drawn
    }

    /// Tetrahedra in the mesh.
    pub fn total(&self) -> usize {
        self.total
    }

    /// CPU time of the visibility masks and the last back-to-front order, ms.
    pub fn order_ms(&self) -> f64 {
        self.masks_ms + self.sort_ms
    }

    /// Records one frame into `encoder`: the tetrahedra in the view's
    /// back-to-front order, rounded to RGBA8, drawn into `target`.
    /// Orthographic cameras only (the traversal is a visibility order for
    /// parallel projection).
    pub fn encode(
        &mut self,
        encoder: &mut wgpu::CommandEncoder,
        target: &Target<'_>,
        camera: &Camera,
    ) -> Result<(), RenderError> {
        self.prepare(target.width, target.height, camera)?;
        let presenter = match &mut self.presenter {
            Some(p) => p,
            None => self.presenter.insert(Presenter::new(&self.gpu)?),
        };
        let images = self.images.as_mut().expect("allocated by prepare");
        draw(encoder, &self.pipeline, &self.group, &images.view, self.drawn);
        images.words.encode(
            &self.gpu,
            presenter,
            encoder,
            ("pt words", &self.words_pipeline, &images.colour),
            target.view,
            target.format,
        )?;
        Ok(())
    }

    /// The image for `width` x `height`, the parameters and the order of
    /// `camera`'s view, written when they changed.
    fn prepare(&mut self, width: u32, height: u32, camera: &Camera) -> Result<(), RenderError> {
        if width == 0 || height == 0 {
            return Err(RenderError::EmptyTarget);
        }
        if camera.perspective {
            return Err(RenderError::PtPerspective);
        }
        self.ensure_images(width, height)?;
        let o = RenderOptions {
            width,
            height,
            azimuth: camera.azimuth,
            elevation: camera.elevation,
            perspective: false,
            ..RenderOptions::default()
        };
        let r = ray_params_for(self.radius, self.dims, &o);
        let params = PtParams {
            camera: r.camera,
            image: [width as i32, height as i32, self.base.image[2], self.base.image[3]],
            ..self.base
        };
        if self.last_params.map(|p| bytemuck::bytes_of(&p) != bytemuck::bytes_of(&params)).unwrap_or(true) {
            self.gpu.queue.write_buffer(&self.params, 0, bytemuck::bytes_of(&params));
            self.last_params = Some(params);
        }
        let forward = [r.camera.forward[0] as f64, r.camera.forward[1] as f64, r.camera.forward[2] as f64];
        if self.last_forward != Some(forward) {
            let started = Instant::now();
            let ids = self.complexes.visible_back_to_front(&self.masks, forward);
            debug_assert_eq!(ids.len(), self.drawn);
            if !ids.is_empty() {
                self.gpu.queue.write_buffer(&self.ids, 0, bytemuck::cast_slice(&ids));
            }
            self.sort_ms = started.elapsed().as_secs_f64() * 1e3;
            self.last_forward = Some(forward);
        }
        Ok(())
    }

    fn ensure_images(&mut self, width: u32, height: u32) -> Result<(), RenderError> {
        if self.images.as_ref().is_some_and(|i| (i.words.width, i.words.height) == (width, height)) {
            return Ok(());
        }
        let gpu = &self.gpu;
        let texture = gpu.checked("pt image", || {
            gpu.device.create_texture(&wgpu::TextureDescriptor {
                label: Some("pt image"),
                size: wgpu::Extent3d { width, height, depth_or_array_layers: 1 },
                mip_level_count: 1,
                sample_count: 1,
                dimension: wgpu::TextureDimension::D2,
                format: BLEND_FORMAT,
                usage: wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::TEXTURE_BINDING,
                view_formats: &[],
            })
        })?;
        let view = texture.create_view(&Default::default());
        let colour = gpu.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("pt colour"),
            layout: &self.colour_layout,
            entries: &[wgpu::BindGroupEntry { binding: 0, resource: wgpu::BindingResource::TextureView(&view) }],
        });
        let image = image_buffer(gpu, "pt words", width, height)?;
        let words = gpu.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("pt words"),
            layout: &self.words_layout,
            entries: &[wgpu::BindGroupEntry { binding: 0, resource: image.as_entire_binding() }],
        });
        self.images = Some(Images { view, colour, words: FrameImage::new(width, height, image, words) });
        Ok(())
    }

    /// The CLI's and the bench's frames: one warm-up and `frames` timed
    /// frames (the draw and the rounding, submit + wait) of `width` x
    /// `height` seen by `camera`, read back as RGBA8.
    pub(crate) fn timed_frames(
        &mut self,
        width: u32,
        height: u32,
        camera: &Camera,
        frames: usize,
    ) -> Result<Frame, RenderError> {
        self.prepare(width, height, camera)?;
        let images = self.images.as_ref().expect("allocated by prepare");
        let mut times = Vec::new();
        for frame in 0..=frames {
            let t0 = Instant::now();
            let mut enc = self.gpu.device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("pt") });
            draw(&mut enc, &self.pipeline, &self.group, &images.view, self.drawn);
            {
                let mut pass = enc.begin_compute_pass(&wgpu::ComputePassDescriptor {
                    label: Some("pt words"),
                    timestamp_writes: None,
                });
                pass.set_pipeline(&self.words_pipeline);
                pass.set_bind_group(0, &images.colour, &[]);
                pass.set_bind_group(1, &images.words.caster, &[]);
                pass.dispatch_workgroups(width.div_ceil(8), height.div_ceil(8), 1);
            }
            self.gpu.queue.submit([enc.finish()]);
            self.gpu.wait()?;
            if frame > 0 {
                times.push(t0.elapsed().as_secs_f64() * 1e3);
            }
        }
        let rgba = self.gpu.read_buffer(&images.words.image)?;
        times.sort_by(f64::total_cmp);
        let ms_per_frame = times.get(times.len() / 2).copied().unwrap_or(f64::NAN);
        let empty_blocks = 1.0 - self.drawn as f64 / self.total.max(1) as f64;
        Ok(Frame { width, height, rgba, ms_per_frame, empty_blocks, skip_map: None })
    }
}

/// The render pipeline of `templates/pt.wgsl` into [`BLEND_FORMAT`],
/// premultiplied "over": what is drawn later (nearer) covers what lies behind.
fn draw_pipeline(
    gpu: &Gpu,
    shader: &wgpu::ShaderModule,
    layout: &wgpu::BindGroupLayout,
) -> Result<wgpu::RenderPipeline, crate::gpu::GpuError> {
    let dev = &gpu.device;
    let pipeline_layout = dev.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
        label: Some("pt"),
        bind_group_layouts: &[Some(layout)],
        immediate_size: 0,
    });
    let over = wgpu::BlendComponent {
        src_factor: wgpu::BlendFactor::One,
        dst_factor: wgpu::BlendFactor::OneMinusSrcAlpha,
        operation: wgpu::BlendOperation::Add,
    };
    gpu.checked("pt pipeline", || {
        dev.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
            label: Some("pt"),
            layout: Some(&pipeline_layout),
            vertex: wgpu::VertexState {
                module: shader,
                entry_point: Some("pt_vs"),
                compilation_options: Default::default(),
                buffers: &[],
            },
            primitive: wgpu::PrimitiveState {
                topology: wgpu::PrimitiveTopology::TriangleList,
                cull_mode: None,
                ..Default::default()
            },
            depth_stencil: None,
            multisample: wgpu::MultisampleState::default(),
            fragment: Some(wgpu::FragmentState {
                module: shader,
                entry_point: Some("pt_fs"),
                compilation_options: Default::default(),
                targets: &[Some(wgpu::ColorTargetState {
                    format: BLEND_FORMAT,
                    blend: Some(wgpu::BlendState { color: over, alpha: over }),
                    write_mask: wgpu::ColorWrites::ALL,
                })],
            }),
            multiview_mask: None,
            cache: None,
        })
    })
}

/// Records the draw of `drawn` tetrahedra (12 vertices each) into `view`,
/// cleared to the ray caster's background.
fn draw(
    encoder: &mut wgpu::CommandEncoder,
    pipeline: &wgpu::RenderPipeline,
    group: &wgpu::BindGroup,
    view: &wgpu::TextureView,
    drawn: usize,
) {
    let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
        label: Some("pt"),
        color_attachments: &[Some(wgpu::RenderPassColorAttachment {
            view,
            depth_slice: None,
            resolve_target: None,
            ops: wgpu::Operations {
                load: wgpu::LoadOp::Clear(wgpu::Color { r: BACKGROUND[0], g: BACKGROUND[1], b: BACKGROUND[2], a: 1.0 }),
                store: wgpu::StoreOp::Store,
            },
        })],
        depth_stencil_attachment: None,
        timestamp_writes: None,
        occlusion_query_set: None,
        multiview_mask: None,
    });
    pass.set_pipeline(pipeline);
    pass.set_bind_group(0, group, &[]);
    if drawn > 0 {
        pass.draw(0..12, 0..drawn as u32);
    }
}
