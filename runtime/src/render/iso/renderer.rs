//! The isosurface renderer a host drives frame by frame: built once (shader
//! compiled, block grids computed, buffers allocated for a size), then
//! [`IsoRenderer::encode`] records a frame into the host's encoder and
//! colour target. A frame after the first at the same size creates no
//! shader module, buffer or texture and writes no texture; it writes the
//! ray parameters only when the camera changed.
//!
//! [`IsoRenderer::encode_with_depth`] takes a host's camera matrix and
//! depth buffer ([`HostDepth`]): rays stop at the host's opaque geometry
//! (no hit behind it; hits in front are the ones without it, bit for bit)
//! and the surface is drawn over the host's colour, misses transparent.

use super::{fine_grid, ray_params_for, raycast_shader_with, Frame, HitMode, RayParams, RenderOptions};
use crate::gpu::binding::layout_entries_from;
use crate::gpu::timing::timed_banded_frames;
use crate::gpu::Gpu;
use crate::render::blocks::{self, block_bounds, SkipMap, SkipMapStats};
use crate::render::camera::{Camera, FrameCamera, HostDepth, Target};
use crate::render::host::HostInput;
use crate::render::present::{image_buffer, FrameImage, Presenter};
use crate::render::RenderError;
use crate::volume::DeviceVolume;
use boxforge::derive::Derivation;

/// What an isosurface looks like, independent of the frame.
#[derive(Clone, Copy, Debug)]
pub struct IsoOptions {
    pub iso: f32,
    /// Ray step in cells (the fixed-step walk).
    pub step: f32,
    /// Edge of the min/max blocks in unit cubes.
    pub block: i32,
    /// Empty-space skipping with the block grid.
    pub skip: bool,
    /// How far a skip jumps (the distance map, or one block).
    pub skip_map: SkipMap,
    /// Fixed steps or exact first hits.
    pub hit: HitMode,
    /// Phong, or curvature shading from `<f>_eval_hessian`.
    pub shade: super::Shade,
}

impl Default for IsoOptions {
    fn default() -> Self {
        IsoOptions::from(&RenderOptions::default())
    }
}

impl From<&RenderOptions> for IsoOptions {
    /// The look of a one-shot render's options (what stays fixed over frames).
    fn from(o: &RenderOptions) -> IsoOptions {
        IsoOptions {
            iso: o.iso,
            step: o.step,
            block: o.block,
            skip: o.skip,
            skip_map: o.skip_map,
            hit: o.hit,
            shade: o.shade,
        }
    }
}

/// An isosurface of one volume with one filter, rendered per frame into a
/// host's target (see the module documentation).
pub struct IsoRenderer {
    gpu: Gpu,
    name: String,
    options: IsoOptions,
    radius: usize,
    dims: [usize; 3],
    pipeline: wgpu::ComputePipeline,
    caster_layout: wgpu::BindGroupLayout,
    /// The shader's bindings table (what its bind groups are built from).
    bindings: Vec<boxforge::validate::Binding>,
    samples: wgpu::BindGroup,
    params: wgpu::Buffer,
    last_params: Option<RayParams>,
    blocks: wgpu::Buffer,
    fine: Option<wgpu::Buffer>,
    empty_blocks: f64,
    skip_map: Option<SkipMapStats>,
    presenter: Presenter,
    host: HostInput,
    /// The image of the current size, the hit depths beside it, and the
    /// host depth its bind group holds (`None`: the dummy).
    frame: Option<(FrameImage, wgpu::Buffer, Option<wgpu::TextureView>)>,
}

impl IsoRenderer {
    /// Compiles the ray caster of `d` for `volume`'s layout, bounds the
    /// blocks with the emitted min/max kernel and binds the samples (the
    /// volume stays shared: other renderers may bind it too).
    pub fn new(
        gpu: &Gpu,
        d: &Derivation,
        volume: &DeviceVolume,
        options: IsoOptions,
    ) -> Result<IsoRenderer, RenderError> {
        let name = d.filter.name.clone();
        let fine = fine_grid(volume.dims, options.block);
        volume.check_filter(d)?;
        let module = volume.emit_options("boxforge_runtime::render::iso::IsoRenderer");
        let source = raycast_shader_with(d, &module, options.hit, fine, true, &options.shade)?;
        let shader = gpu.compile(&format!("{name}.raycast.wgsl"), &source)?;
        let bounds = block_bounds(gpu, &shader, &name, volume, volume.dims, options.block)?;
        let empty: Vec<u32> = bounds.iter().map(|b| (options.iso < b[0] || options.iso > b[1]) as u32).collect();
        let empty_blocks = empty.iter().filter(|&&e| e != 0).count() as f64 / bounds.len().max(1) as f64;
        // The distance map rides after the bounds in the same buffer (skipping mode 2).
        let (blocks, skip_map) = if options.skip && options.skip_map != SkipMap::OneBlock {
            let grid = blocks::blocks_per_axis(volume.dims, options.block);
            let (distances, stats) = blocks::skip_map(&empty, grid, 0, options.skip_map);
            (blocks::upload(gpu, "blocks", &blocks::bounds_with_distances(&bounds, &distances)), Some(stats))
        } else {
            (blocks::upload(gpu, "blocks", &bounds), None)
        };
        let fine = if options.hit == HitMode::Exact {
            Some(blocks::upload(gpu, "fine blocks", &block_bounds(gpu, &shader, &name, volume, volume.dims, fine.0)?))
        } else {
            None
        };
        let dev = &gpu.device;
        let samples_layout = dev.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("samples"),
            entries: &volume.layout_entries(0, wgpu::ShaderStages::COMPUTE),
        });
        // Group 1 (parameters, image, block grids, depth, host depth) as the template declares it.
        let bindings = gpu.bindings_of(&source)?;
        let caster_layout = dev.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("raycast"),
            entries: &layout_entries_from(&bindings, 1)?,
        });
        let pipeline =
            gpu.pipeline("raycast", &shader, &[&samples_layout, &caster_layout], &format!("{name}_raycast_main"))?;
        let samples = dev.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("samples"),
            layout: &samples_layout,
            entries: &volume.bind_entries(0),
        });
        let params = gpu.uniform_buffer("ray params", bytemuck::bytes_of(&RayParams::zeroed()));
        Ok(IsoRenderer {
            gpu: gpu.clone(),
            name,
            options,
            radius: crate::volume::support_radius(d),
            dims: volume.dims,
            pipeline,
            caster_layout,
            bindings,
            samples,
            params,
            last_params: None,
            blocks,
            fine,
            empty_blocks,
            skip_map,
            presenter: Presenter::new(gpu)?,
            host: HostInput::new(gpu),
            frame: None,
        })
    }

    /// The fraction of blocks whose bounds exclude the iso-value.
    pub fn empty_blocks(&self) -> f64 {
        self.empty_blocks
    }

    /// The distance map's build time and size (None: skipping off or one block at a time).
    pub fn skip_map_stats(&self) -> Option<SkipMapStats> {
        self.skip_map
    }

    /// The filter this renderer evaluates.
    pub fn filter_name(&self) -> &str {
        &self.name
    }

    /// Records one frame into `encoder`: the ray caster (one dispatch), then
    /// the image drawn into `target`. Buffers are (re)allocated only when
    /// the target's size or format changes.
    pub fn encode(
        &mut self,
        encoder: &mut wgpu::CommandEncoder,
        target: &Target<'_>,
        camera: &Camera,
    ) -> Result<(), RenderError> {
        self.encode_with_depth(encoder, target, FrameCamera::Orbit(*camera), None)
    }

    /// [`IsoRenderer::encode`] with the rays of `camera` (an orbit, or a
    /// host's view-projection) and, with `depth`, stopped at the host's
    /// opaque geometry: no hit is reported behind it, and the frame is drawn
    /// over the target's contents (the host's colour) with misses
    /// transparent. `depth` must have been drawn with `camera`'s
    /// view-projection ([`crate::render::Camera::view_projection`] for an
    /// orbit); see [`HostDepth`] for the formats. Without `depth` the frame
    /// is [`IsoRenderer::encode`]'s.
    pub fn encode_with_depth(
        &mut self,
        encoder: &mut wgpu::CommandEncoder,
        target: &Target<'_>,
        camera: FrameCamera,
        depth: Option<HostDepth<'_>>,
    ) -> Result<(), RenderError> {
        if target.width == 0 || target.height == 0 {
            return Err(RenderError::EmptyTarget);
        }
        if let Some(d) = &depth {
            d.check(target.width, target.height)?;
        }
        self.ensure_image(target.width, target.height, depth.as_ref())?;
        let orbit = match camera {
            FrameCamera::Orbit(c) => c,
            FrameCamera::ViewProj(_) => Camera::default(),
        };
        let o = RenderOptions {
            iso: self.options.iso,
            width: target.width,
            height: target.height,
            azimuth: orbit.azimuth,
            elevation: orbit.elevation,
            perspective: orbit.perspective,
            skip: self.options.skip,
            skip_map: self.options.skip_map,
            step: self.options.step,
            block: self.options.block,
            hit: self.options.hit,
            ..RenderOptions::default()
        };
        let mut params = ray_params_for(self.radius, self.dims, &o);
        let (lo, hi) = (box3(params.camera.box_lo), box3(params.camera.box_hi));
        let (uniform, perspective, view_proj) = camera.resolve(lo, hi, target.width, target.height);
        params.camera = uniform;
        params.shade[2] = perspective as i32 as f32;
        if self.last_params.map(|p| bytemuck::bytes_of(&p) != bytemuck::bytes_of(&params)).unwrap_or(true) {
            self.gpu.queue.write_buffer(&self.params, 0, bytemuck::bytes_of(&params));
            self.last_params = Some(params);
        }
        self.host.write(&self.gpu, view_proj, depth.is_some());
        let (frame, _, _) = self.frame.as_mut().expect("allocated above");
        frame.encode_over(
            &self.gpu,
            &mut self.presenter,
            encoder,
            ("raycast", &self.pipeline, &self.samples),
            target.view,
            target.format,
            depth.is_some(),
        )?;
        Ok(())
    }

    /// The valid box the rays run through (the filter's support inside the
    /// volume), in sample-index coordinates: where a host places the volume.
    pub fn valid_box(&self) -> ([f32; 3], [f32; 3]) {
        let p =
            ray_params_for(self.radius, self.dims, &RenderOptions { block: self.options.block, ..Default::default() });
        (box3(p.camera.box_lo), box3(p.camera.box_hi))
    }

    /// The buffer of the last frame's hit depths (ray parameter t per pixel,
    /// -1 for a miss), which a host may bind or copy.
    pub fn depth_buffer(&self) -> Option<&wgpu::Buffer> {
        self.frame.as_ref().map(|(_, depth, _)| depth)
    }

    /// The last frame's image buffer (one RGBA8 word per pixel, rows from the top).
    pub fn image_buffer(&self) -> Option<&wgpu::Buffer> {
        self.frame.as_ref().map(|(f, _, _)| &f.image)
    }

    /// The image and depth buffers and the caster's bind group for a
    /// `width` x `height` frame (kept while the size stays; the bind group
    /// is rebuilt when the host's depth view changes).
    fn ensure_image(&mut self, width: u32, height: u32, host: Option<&HostDepth<'_>>) -> Result<(), RenderError> {
        let wanted = host.map(|d| d.view);
        let view = self.host.view(host);
        if let Some((f, depth, bound)) = self.frame.as_mut().filter(|(f, _, _)| (f.width, f.height) == (width, height))
        {
            if bound.as_ref() != wanted {
                let buffers = caster_buffers(&self.params, &f.image, &self.blocks, depth, self.fine.as_ref());
                f.caster =
                    self.host.bind_group(&self.gpu, "raycast", &self.caster_layout, &self.bindings, &buffers, view);
                *bound = wanted.cloned();
            }
            return Ok(());
        }
        let image = image_buffer(&self.gpu, "image", width, height)?;
        let depth = image_buffer(&self.gpu, "depth", width, height)?;
        let buffers = caster_buffers(&self.params, &image, &self.blocks, &depth, self.fine.as_ref());
        let caster = self.host.bind_group(&self.gpu, "raycast", &self.caster_layout, &self.bindings, &buffers, view);
        self.frame = Some((FrameImage::new(width, height, image, caster), depth, wanted.cloned()));
        Ok(())
    }

    /// The CLI's and the bench's frames: one warm-up and `o.frames` timed
    /// frames of `o.width` x `o.height` (in bands of rows with a progress
    /// bar when `o.progress`), read back as RGBA8 and hit depths.
    pub(crate) fn timed_frames(&mut self, o: &RenderOptions) -> Result<(Frame, Vec<f32>), RenderError> {
        self.ensure_image(o.width, o.height, None)?;
        self.host.write(&self.gpu, glam::Mat4::IDENTITY, false);
        let mut params = ray_params_for(self.radius, self.dims, o);
        // The skipping this renderer was built for (the map is there or not).
        params.shade[3] = super::skip_mode(self.options.skip, self.options.skip_map);
        let (frame, depth, _) = self.frame.as_ref().expect("allocated above");
        let times = timed_banded_frames(
            &self.gpu,
            &self.pipeline,
            [&self.samples, &frame.caster],
            (&self.params, params, |p: &mut RayParams, y0| p.image[3] = y0 as i32),
            (o.width, o.height, if o.progress { 32 } else { o.height }),
            ("raycast", "rendering rows", o.progress),
            o.frames.max(1),
        )?;
        // The bands rewrote the parameters: the next encode writes its own.
        self.last_params = None;
        let words: Vec<u32> = bytemuck::cast_slice(&self.gpu.read_buffer(&frame.image)?).to_vec();
        let rgba = words.iter().flat_map(|w| w.to_le_bytes()).collect();
        let depth: Vec<f32> = bytemuck::cast_slice(&self.gpu.read_buffer(depth)?).to_vec();
        let ms_per_frame = times[times.len() / 2];
        Ok((
            Frame {
                width: o.width,
                height: o.height,
                rgba,
                ms_per_frame,
                empty_blocks: self.empty_blocks,
                skip_map: self.skip_map,
            },
            depth,
        ))
    }
}

/// The caster's buffers by binding (parameters, image, blocks, hit depths,
/// fine blocks: the coarse ones stand in for the step walk, which declares none).
fn caster_buffers<'a>(
    params: &'a wgpu::Buffer,
    image: &'a wgpu::Buffer,
    blocks: &'a wgpu::Buffer,
    depth: &'a wgpu::Buffer,
    fine: Option<&'a wgpu::Buffer>,
) -> [(u32, &'a wgpu::Buffer); 5] {
    [(0, params), (1, image), (2, blocks), (3, depth), (4, fine.unwrap_or(blocks))]
}

/// The xyz of a uniform vector.
fn box3(a: [f32; 4]) -> [f32; 3] {
    [a[0], a[1], a[2]]
}

use bytemuck::Zeroable as _;
