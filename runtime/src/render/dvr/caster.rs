//! The per-frame core of the ray casters built on the DVR template other
//! than [`super::DvrRenderer`] (the PERM cache's lookup, the hand-written
//! plane-stack schemes): the group-1 resources of `templates/dvr.wgsl.j2`
//! (parameters, image, skipping flags, 1D table, pre-integration table)
//! plus what a caster adds after binding 4, kept for the renderer's life;
//! the image of the current size; and the two ways a frame is run, into a
//! host's target ([`DvrCaster::encode`]) or timed and read back for the CLI
//! and the bench ([`DvrCaster::timed_frames`]). Both write the same
//! parameters from the same options, so the one-shot image is the frame's.
//! The pipeline is the caller's per frame: a scheme switches modules with
//! the view's plane stack, all laid out on this core's two groups.

use super::params::{dvr_params_for, DvrParams};
use super::skip::{empty_flags, skip_distances};
use super::transfer::{Preint, Tf1d};
use super::{DvrLook, DvrOptions};
use crate::gpu::timing::timed_banded_frames;
use crate::gpu::Gpu;
use crate::render::camera::{Camera, Target};
use crate::render::iso::Frame;
use crate::render::present::{image_buffer, FrameImage, Presenter};
use crate::render::RenderError;

/// A group-1 resource a caster adds after the DVR template's five.
#[derive(Clone)]
pub(crate) enum Extra {
    Buffer(wgpu::Buffer),
    Texture(wgpu::TextureView),
}

/// What a DVR-template caster is built from besides the look and the table.
pub(crate) struct CasterParts {
    /// Label of the passes and buffers.
    pub label: &'static str,
    /// Cells the evaluated function's support reaches (the valid box's margin).
    pub radius: usize,
    /// Samples per axis of the volume.
    pub dims: [usize; 3],
    /// [min, max] of the function over each block of `look.block` cubes.
    pub bounds: Vec<[f32; 2]>,
    /// Group 0 (the samples): its layout and bind group.
    pub samples: (wgpu::BindGroupLayout, wgpu::BindGroup),
    /// Group 1's layout: the template's bindings 0 to 4 and the extras'.
    pub layout: wgpu::BindGroupLayout,
    /// The extras, by binding.
    pub extra: Vec<(u32, Extra)>,
}

/// See the module documentation.
pub(crate) struct DvrCaster {
    gpu: Gpu,
    label: &'static str,
    look: DvrLook,
    radius: usize,
    dims: [usize; 3],
    table: Tf1d,
    pi_size: usize,
    empty_blocks: f64,
    skip_map: crate::render::blocks::SkipMapStats,
    samples_layout: wgpu::BindGroupLayout,
    samples: wgpu::BindGroup,
    layout: wgpu::BindGroupLayout,
    params: wgpu::Buffer,
    last_params: Option<DvrParams>,
    /// Skipping flags, 1D table, pre-integration table (bindings 2 to 4).
    tables: [wgpu::Buffer; 3],
    extra: Vec<(u32, Extra)>,
    /// Built by the first frame into a host's target (the one-shot frames need none).
    presenter: Option<Presenter>,
    frame: Option<FrameImage>,
}

impl DvrCaster {
    /// Uploads `table`'s entries, its pre-integration for `look.step` when
    /// `look.preintegrate`, and the skipping flags of `parts.bounds`.
    pub(crate) fn new(gpu: &Gpu, table: Tf1d, look: DvrLook, parts: CasterParts) -> Result<DvrCaster, RenderError> {
        let pi = look.preintegrate.then(|| table.preintegrate(look.step as f64));
        Self::with_preint(gpu, table, pi.as_ref(), look, parts)
    }

    /// [`DvrCaster::new`] with the pre-integration table already built (for
    /// `look.step`; None: point samples, whatever `look.preintegrate` says).
    pub(crate) fn with_preint(
        gpu: &Gpu,
        table: Tf1d,
        pi: Option<&Preint>,
        look: DvrLook,
        parts: CasterParts,
    ) -> Result<DvrCaster, RenderError> {
        let look = DvrLook { preintegrate: pi.is_some(), ..look };
        let empty = empty_flags(&parts.bounds, &table);
        let empty_blocks = empty.iter().filter(|&&f| f != 0).count() as f64 / empty.len().max(1) as f64;
        let blocks = crate::render::blocks::blocks_per_axis(parts.dims, look.block);
        let (flags, skip_map) =
            skip_distances(&empty, blocks, (look.step / look.block as f32).ceil() as i32, look.skip_map);
        let pi_entries: Vec<[f32; 4]> = pi.map_or_else(|| vec![[0.0; 4]; 4], |p| p.entries.clone());
        let label = parts.label;
        Ok(DvrCaster {
            gpu: gpu.clone(),
            label,
            look,
            radius: parts.radius,
            dims: parts.dims,
            pi_size: pi.map_or(2, |p| p.size),
            empty_blocks,
            skip_map,
            samples_layout: parts.samples.0,
            samples: parts.samples.1,
            layout: parts.layout,
            params: gpu.uniform_buffer(&format!("{label} params"), &[0u8; std::mem::size_of::<DvrParams>()]),
            last_params: None,
            tables: [
                gpu.storage_buffer(&format!("{label} flags"), bytemuck::cast_slice(&flags), false),
                gpu.storage_buffer(&format!("{label} tf"), bytemuck::cast_slice(&table.entries), false),
                gpu.storage_buffer(&format!("{label} preint"), bytemuck::cast_slice(&pi_entries), false),
            ],
            table,
            extra: parts.extra,
            presenter: None,
            frame: None,
        })
    }

    /// A compute pipeline of `shader`'s `entry` on this core's two groups.
    pub(crate) fn pipeline(
        &self,
        shader: &wgpu::ShaderModule,
        entry: &str,
    ) -> Result<wgpu::ComputePipeline, RenderError> {
        Ok(self.gpu.pipeline(self.label, shader, &[&self.samples_layout, &self.layout], entry)?)
    }

    /// The fraction of blocks the transfer function leaves transparent.
    pub(crate) fn empty_blocks(&self) -> f64 {
        self.empty_blocks
    }

    /// The options of a frame of `width` x `height` seen by `camera`.
    fn options(&self, width: u32, height: u32, camera: &Camera) -> DvrOptions {
        let l = self.look;
        DvrOptions {
            width,
            height,
            azimuth: camera.azimuth,
            elevation: camera.elevation,
            perspective: camera.perspective,
            skip: l.skip,
            skip_map: l.skip_map,
            preintegrate: l.preintegrate,
            step: l.step,
            block: l.block,
            termination: l.termination,
            ..DvrOptions::default()
        }
    }

    fn params_for(&self, o: &DvrOptions) -> DvrParams {
        dvr_params_for(self.radius, self.dims, &self.table, self.pi_size, o)
    }

    /// Records one frame of `pipeline` into `encoder`, then the image drawn
    /// into `target`; the parameters are written only when they changed.
    pub(crate) fn encode(
        &mut self,
        pipeline: &wgpu::ComputePipeline,
        encoder: &mut wgpu::CommandEncoder,
        target: &Target<'_>,
        camera: &Camera,
    ) -> Result<(), RenderError> {
        if target.width == 0 || target.height == 0 {
            return Err(RenderError::EmptyTarget);
        }
        self.ensure_image(target.width, target.height)?;
        let params = self.params_for(&self.options(target.width, target.height, camera));
        if self.last_params.map(|p| bytemuck::bytes_of(&p) != bytemuck::bytes_of(&params)).unwrap_or(true) {
            self.gpu.queue.write_buffer(&self.params, 0, bytemuck::bytes_of(&params));
            self.last_params = Some(params);
        }
        let presenter = match &mut self.presenter {
            Some(p) => p,
            None => self.presenter.insert(Presenter::new(&self.gpu)?),
        };
        let frame = self.frame.as_mut().expect("allocated above");
        frame.encode(
            &self.gpu,
            presenter,
            encoder,
            (self.label, pipeline, &self.samples),
            target.view,
            target.format,
        )?;
        Ok(())
    }

    /// The CLI's and the bench's frames of `pipeline` at `o`'s size and
    /// camera (the look is this core's): one warm-up and `o.frames` timed
    /// frames, in bands of rows with a progress bar when `o.progress`,
    /// read back as RGBA8.
    pub(crate) fn timed_frames(
        &mut self,
        pipeline: &wgpu::ComputePipeline,
        o: &DvrOptions,
    ) -> Result<Frame, RenderError> {
        if o.width == 0 || o.height == 0 {
            return Err(RenderError::EmptyTarget);
        }
        self.ensure_image(o.width, o.height)?;
        let camera = Camera { azimuth: o.azimuth, elevation: o.elevation, perspective: o.perspective };
        let params = self.params_for(&self.options(o.width, o.height, &camera));
        let frame = self.frame.as_ref().expect("allocated above");
        let times = timed_banded_frames(
            &self.gpu,
            pipeline,
            [&self.samples, &frame.caster],
            (&self.params, params, |p: &mut DvrParams, y0| p.image[3] = y0 as i32),
            (o.width, o.height, if o.progress { 16 } else { o.height }),
            (self.label, "volume rendering rows", o.progress),
            o.frames,
        )?;
        // The bands rewrote the parameters: the next encode writes its own.
        self.last_params = None;
        let ms_per_frame = if times.is_empty() { f64::NAN } else { times[times.len() / 2] };
        self.read_image(ms_per_frame)
    }

    /// The current image read back as RGBA8, with `ms_per_frame`.
    pub(crate) fn read_image(&self, ms_per_frame: f64) -> Result<Frame, RenderError> {
        let frame = self.frame.as_ref().ok_or(RenderError::EmptyTarget)?;
        let words: Vec<u32> = bytemuck::cast_slice(&self.gpu.read_buffer(&frame.image)?).to_vec();
        let rgba = words.iter().flat_map(|w| w.to_le_bytes()).collect();
        Ok(Frame {
            width: frame.width,
            height: frame.height,
            rgba,
            ms_per_frame,
            empty_blocks: self.empty_blocks,
            skip_map: Some(self.skip_map),
        })
    }

    /// Sets up a frame dispatched by the caller (out of core, in passes):
    /// the image of `o`'s size and the parameters of its camera with this
    /// core's look.
    pub(crate) fn prepare(&mut self, o: &DvrOptions) -> Result<(), RenderError> {
        if o.width == 0 || o.height == 0 {
            return Err(RenderError::EmptyTarget);
        }
        self.ensure_image(o.width, o.height)?;
        let camera = Camera { azimuth: o.azimuth, elevation: o.elevation, perspective: o.perspective };
        let params = self.params_for(&self.options(o.width, o.height, &camera));
        self.gpu.queue.write_buffer(&self.params, 0, bytemuck::bytes_of(&params));
        self.last_params = Some(params);
        Ok(())
    }

    /// One dispatch of `pipeline` over the whole prepared image.
    pub(crate) fn dispatch_image(&self, pipeline: &wgpu::ComputePipeline) -> Result<(), RenderError> {
        let frame = self.frame.as_ref().ok_or(RenderError::NoFrame)?;
        Ok(self.gpu.dispatch(
            self.label,
            pipeline,
            &[&self.samples, &frame.caster],
            (frame.width.div_ceil(8), frame.height.div_ceil(8), 1),
        )?)
    }

    /// The image and the group-1 bind group for a `width` x `height` frame
    /// (kept while the size stays).
    fn ensure_image(&mut self, width: u32, height: u32) -> Result<(), RenderError> {
        if self.frame.as_ref().is_some_and(|f| (f.width, f.height) == (width, height)) {
            return Ok(());
        }
        let image = image_buffer(&self.gpu, &format!("{} image", self.label), width, height)?;
        let [flags, tf, preint] = &self.tables;
        let mut entries = vec![
            wgpu::BindGroupEntry { binding: 0, resource: self.params.as_entire_binding() },
            wgpu::BindGroupEntry { binding: 1, resource: image.as_entire_binding() },
            wgpu::BindGroupEntry { binding: 2, resource: flags.as_entire_binding() },
            wgpu::BindGroupEntry { binding: 3, resource: tf.as_entire_binding() },
            wgpu::BindGroupEntry { binding: 4, resource: preint.as_entire_binding() },
        ];
        entries.extend(self.extra.iter().map(|(binding, e)| wgpu::BindGroupEntry {
            binding: *binding,
            resource: match e {
                Extra::Buffer(b) => b.as_entire_binding(),
                Extra::Texture(v) => wgpu::BindingResource::TextureView(v),
            },
        }));
        let caster = self.gpu.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some(self.label),
            layout: &self.layout,
            entries: &entries,
        });
        self.frame = Some(FrameImage::new(width, height, image, caster));
        Ok(())
    }
}

/// The look of one-shot options `o`.
pub(crate) fn look_of(o: &DvrOptions) -> DvrLook {
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
