//! The direct volume renderer a host drives frame by frame, the DVR
//! counterpart of [`crate::render::IsoRenderer`]: built once with a
//! transfer function (shader compiled, block bounds, tables, skipping flags
//! and pre-integration uploaded), then [`DvrRenderer::encode`] records a
//! frame into the host's encoder and colour target. Frames after the first
//! at one size create no buffer, texture or shader module.
//!
//! [`DvrRenderer::encode_with_depth`] takes a host's camera matrix and
//! depth buffer ([`HostDepth`]): each ray composites up to the host's
//! opaque geometry (the segment it cuts weighted by the fraction in front)
//! and the frame is premultiplied colour and opacity over the host's colour.

use super::params::{dvr_params_for, DvrParams};
use super::skip::{empty_flags, skip_distances};
use super::transfer::TransferFunction;
use super::{filter_module_with, DvrOptions};
use crate::gpu::binding::layout_entries_from;
use crate::gpu::Gpu;
use crate::render::blocks::block_bounds;
use crate::render::camera::{Camera, FrameCamera, HostDepth, Target};
use crate::render::host::HostInput;
use crate::render::present::{image_buffer, FrameImage, Presenter};
use crate::render::RenderError;
use crate::volume::DeviceVolume;
use boxforge::derive::Derivation;

/// How a volume rendering looks, independent of the frame.
#[derive(Clone, Copy, Debug)]
pub struct DvrLook {
    /// Segment length in cells.
    pub step: f32,
    /// Edge of the skipping blocks in unit cubes.
    pub block: i32,
    /// Transfer-function-aware empty-space skipping.
    pub skip: bool,
    /// How far a skip jumps (the distance map, or one block).
    pub skip_map: crate::render::blocks::SkipMap,
    /// Pre-integrated segments (else point samples).
    pub preintegrate: bool,
    /// Early ray termination opacity.
    pub termination: f32,
    /// The curvature transfer function's radius (None: the value TF alone).
    pub curvature: Option<f32>,
}

impl From<&DvrOptions> for DvrLook {
    /// The look of one-shot options (their frame fields dropped).
    fn from(o: &DvrOptions) -> DvrLook {
        super::caster::look_of(o)
    }
}

impl Default for DvrLook {
    fn default() -> Self {
        let o = DvrOptions::default();
        super::caster::look_of(&o)
    }
}

/// A volume rendering of one volume with one filter and transfer function.
pub struct DvrRenderer {
    gpu: Gpu,
    look: DvrLook,
    radius: usize,
    dims: [usize; 3],
    table: super::transfer::Tf1d,
    pi_size: usize,
    empty_blocks: f64,
    skip_map: crate::render::blocks::SkipMapStats,
    pipeline: wgpu::ComputePipeline,
    caster_layout: wgpu::BindGroupLayout,
    /// The shader's bindings table (what its bind groups are built from).
    bindings: Vec<boxforge::validate::Binding>,
    samples: wgpu::BindGroup,
    params: wgpu::Buffer,
    last_params: Option<DvrParams>,
    flags: wgpu::Buffer,
    tf: wgpu::Buffer,
    preint: wgpu::Buffer,
    presenter: Presenter,
    host: HostInput,
    /// The image of the current size and the host depth its bind group
    /// holds (`None`: the dummy).
    frame: Option<(FrameImage, Option<wgpu::TextureView>)>,
}

impl DvrRenderer {
    /// Compiles the DVR ray caster of `d` for `volume`'s layout, bounds its
    /// blocks, and uploads `tf`'s tables and the skipping flags.
    pub fn new(
        gpu: &Gpu,
        d: &Derivation,
        volume: &DeviceVolume,
        tf: &TransferFunction,
        look: DvrLook,
    ) -> Result<DvrRenderer, RenderError> {
        let name = &d.filter.name;
        volume.check_filter(d)?;
        let module = filter_module_with(d, &volume.emit_options(super::DVR_COMMAND))?;
        if let Some(radius) = look.curvature {
            super::check_curvature_tf(d, radius)?;
        }
        let source = format!("{}\n{}", module, super::dvr_template_curvature(name, false, true, look.curvature));
        let shader = gpu.compile(&format!("{name}.dvr.wgsl"), &source)?;
        // Group 1 (parameters, image, skipping flags, tables, host depth) as the template declares it.
        let bindings = gpu.bindings_of(&source)?;
        let bounds = block_bounds(gpu, &shader, name, volume, volume.dims, look.block)?;
        let table = tf.table();
        let pi = look.preintegrate.then(|| table.preintegrate(look.step as f64));
        let empty = empty_flags(&bounds, &table);
        let empty_blocks = empty.iter().filter(|&&f| f != 0).count() as f64 / empty.len().max(1) as f64;
        let blocks = crate::render::blocks::blocks_per_axis(volume.dims, look.block);
        let radius = (look.step / look.block as f32).ceil() as i32;
        let (flags, skip_map) = skip_distances(&empty, blocks, radius, look.skip_map);
        let pi_entries: Vec<[f32; 4]> = pi.as_ref().map_or_else(|| vec![[0.0; 4]; 4], |p| p.entries.clone());
        let dev = &gpu.device;
        let samples_layout = dev.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("samples"),
            entries: &volume.layout_entries(0, wgpu::ShaderStages::COMPUTE),
        });
        let caster_layout = dev.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("dvr"),
            entries: &layout_entries_from(&bindings, 1)?,
        });
        let pipeline = gpu.pipeline("dvr", &shader, &[&samples_layout, &caster_layout], &format!("{name}_dvr_main"))?;
        let samples = dev.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("samples"),
            layout: &samples_layout,
            entries: &volume.bind_entries(0),
        });
        Ok(DvrRenderer {
            gpu: gpu.clone(),
            look,
            radius: crate::volume::support_radius(d),
            dims: volume.dims,
            pi_size: pi.as_ref().map_or(2, |p| p.size),
            empty_blocks,
            skip_map,
            pipeline,
            caster_layout,
            bindings,
            samples,
            params: gpu.uniform_buffer("dvr params", &[0u8; std::mem::size_of::<DvrParams>()]),
            last_params: None,
            flags: gpu.storage_buffer("dvr flags", bytemuck::cast_slice(&flags), false),
            tf: gpu.storage_buffer("dvr tf", bytemuck::cast_slice(&table.entries), false),
            preint: gpu.storage_buffer("dvr preint", bytemuck::cast_slice(&pi_entries), false),
            table,
            presenter: Presenter::new(gpu)?,
            host: HostInput::new(gpu),
            frame: None,
        })
    }

    /// The fraction of blocks the transfer function leaves transparent.
    pub fn empty_blocks(&self) -> f64 {
        self.empty_blocks
    }

    /// The skipping map's build time and size.
    pub fn skip_map_stats(&self) -> crate::render::blocks::SkipMapStats {
        self.skip_map
    }

    /// Records one frame into `encoder`: the DVR ray caster, then the image
    /// drawn into `target`.
    pub fn encode(
        &mut self,
        encoder: &mut wgpu::CommandEncoder,
        target: &Target<'_>,
        camera: &Camera,
    ) -> Result<(), RenderError> {
        self.encode_with_depth(encoder, target, FrameCamera::Orbit(*camera), None)
    }

    /// [`DvrRenderer::encode`] with the rays of `camera` (an orbit, or a
    /// host's view-projection) and, with `depth`, composited only up to the
    /// host's opaque geometry and drawn over the target's contents (the
    /// host's colour) as premultiplied colour and opacity. `depth` must have
    /// been drawn with `camera`'s view-projection; see [`HostDepth`] for the
    /// formats. Without `depth` the frame is [`DvrRenderer::encode`]'s.
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
        let o = DvrOptions {
            width: target.width,
            height: target.height,
            azimuth: orbit.azimuth,
            elevation: orbit.elevation,
            perspective: orbit.perspective,
            skip: self.look.skip,
            preintegrate: self.look.preintegrate,
            step: self.look.step,
            block: self.look.block,
            termination: self.look.termination,
            ..DvrOptions::default()
        };
        let mut params = dvr_params_for(self.radius, self.dims, &self.table, self.pi_size, &o);
        let xyz = |a: [f32; 4]| [a[0], a[1], a[2]];
        let (uniform, perspective, view_proj) =
            camera.resolve(xyz(params.camera.box_lo), xyz(params.camera.box_hi), target.width, target.height);
        params.camera = uniform;
        params.mode[0] = perspective as i32 as f32;
        if self.last_params.map(|p| bytemuck::bytes_of(&p) != bytemuck::bytes_of(&params)).unwrap_or(true) {
            self.gpu.queue.write_buffer(&self.params, 0, bytemuck::bytes_of(&params));
            self.last_params = Some(params);
        }
        self.host.write(&self.gpu, view_proj, depth.is_some());
        let (frame, _) = self.frame.as_mut().expect("allocated above");
        frame.encode_over(
            &self.gpu,
            &mut self.presenter,
            encoder,
            ("dvr", &self.pipeline, &self.samples),
            target.view,
            target.format,
            depth.is_some(),
        )?;
        Ok(())
    }

    /// The valid box the rays run through, in sample-index coordinates
    /// (as [`crate::render::IsoRenderer::valid_box`]).
    pub fn valid_box(&self) -> ([f32; 3], [f32; 3]) {
        let o = crate::render::iso::RenderOptions { block: self.look.block, ..Default::default() };
        let c = crate::render::iso::ray_params_for(self.radius, self.dims, &o).camera;
        ([c.box_lo[0], c.box_lo[1], c.box_lo[2]], [c.box_hi[0], c.box_hi[1], c.box_hi[2]])
    }

    /// The last frame's image buffer (one RGBA8 word per pixel, rows from
    /// the top; premultiplied colour and opacity in a frame with a host depth).
    pub fn image_buffer(&self) -> Option<&wgpu::Buffer> {
        self.frame.as_ref().map(|(f, _)| &f.image)
    }

    fn ensure_image(&mut self, width: u32, height: u32, host: Option<&HostDepth<'_>>) -> Result<(), RenderError> {
        let wanted = host.map(|d| d.view);
        let view = self.host.view(host);
        let buffers = |image| [(0, &self.params), (1, image), (2, &self.flags), (3, &self.tf), (4, &self.preint)];
        if let Some((f, bound)) = self.frame.as_mut().filter(|(f, _)| (f.width, f.height) == (width, height)) {
            if bound.as_ref() != wanted {
                f.caster = self.host.bind_group(
                    &self.gpu,
                    "dvr",
                    &self.caster_layout,
                    &self.bindings,
                    &buffers(&f.image),
                    view,
                );
                *bound = wanted.cloned();
            }
            return Ok(());
        }
        let image = image_buffer(&self.gpu, "dvr image", width, height)?;
        let caster =
            self.host.bind_group(&self.gpu, "dvr", &self.caster_layout, &self.bindings, &buffers(&image), view);
        self.frame = Some((FrameImage::new(width, height, image, caster), wanted.cloned()));
        Ok(())
    }
}
