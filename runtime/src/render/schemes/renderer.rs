//! The plane-stack schemes' renderer a host drives frame by frame. A
//! scheme's module depends on the view (the plane stack is the axis of the
//! view's largest component), so the renderer keeps one ray-casting
//! pipeline per stack, each compiled the first time a frame looks along
//! its axis and kept; everything else (the samples' binding, the widened
//! block bounds and skipping flags, the tables, the image) is shared by the
//! three and built once, as [`crate::render::DvrRenderer`] builds its own.
//! Frames after the first along each axis, at one size, create no buffer,
//! texture or shader module.

use super::{base, choice_line, dvr_source, stack_for_view, Scheme, REACH};
use crate::gpu::Gpu;
use crate::render::blocks::block_bounds;
use crate::render::camera::{Camera, Target};
use crate::render::dvr::caster::{CasterParts, DvrCaster};
use crate::render::dvr::transfer::TransferFunction;
use crate::render::dvr::{caster_entries, widen_bounds, DvrLook, DvrOptions};
use crate::render::iso::Frame;
use crate::render::RenderError;
use crate::volume::DeviceVolume;
use boxforge::derive::Derivation;
use boxforge::emit::Layout;

/// A hand-written scheme's volume rendering of one BCC volume.
pub struct SchemeRenderer {
    gpu: Gpu,
    scheme: Scheme,
    base: Derivation,
    core: DvrCaster,
    /// The ray caster of each plane stack (x, y, z), once compiled.
    stacks: [Option<wgpu::ComputePipeline>; 3],
}

impl SchemeRenderer {
    /// Binds `volume` (BCC samples in the embedded layout, shared), bounds
    /// its blocks for skipping (`bcc_linear`'s cell bounds widened by
    /// [`REACH`]), uploads `tf`'s tables, and compiles the stack of the
    /// default camera's view.
    pub fn new(
        gpu: &Gpu,
        volume: &DeviceVolume,
        scheme: Scheme,
        tf: &TransferFunction,
        look: DvrLook,
    ) -> Result<SchemeRenderer, RenderError> {
        Self::with_first_stack(gpu, volume, scheme, tf, look, stack_for_view(Camera::default().view_direction()))
    }

    /// [`SchemeRenderer::new`], compiling stack `axis` first (the one the
    /// first frame looks along saves a compilation).
    pub(crate) fn with_first_stack(
        gpu: &Gpu,
        volume: &DeviceVolume,
        scheme: Scheme,
        tf: &TransferFunction,
        look: DvrLook,
        axis: usize,
    ) -> Result<SchemeRenderer, RenderError> {
        let base = base()?;
        if volume.lattice != base.filter.lattice {
            return Err(RenderError::SchemeLattice { scheme: scheme.name(), lattice: volume.lattice.name.clone() });
        }
        if volume.layout != Layout::Embedded {
            return Err(RenderError::SchemeLayout { scheme: scheme.name() });
        }
        let shader = compile(gpu, &base, scheme, axis)?;
        // Every stack's module holds bcc_linear's min/max kernel: the bounds are the stacks' too.
        let cells = block_bounds(gpu, &shader, &base.filter.name, volume, volume.dims, 1)?;
        let bounds = widen_bounds(&cells, volume.dims, look.block as usize, REACH);
        let dev = &gpu.device;
        let samples_layout = dev.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("samples"),
            entries: &volume.layout_entries(0, wgpu::ShaderStages::COMPUTE),
        });
        let samples = dev.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("samples"),
            layout: &samples_layout,
            entries: &volume.bind_entries(0),
        });
        let layout = dev.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("dvr"),
            entries: &caster_entries(gpu),
        });
        let parts = CasterParts {
            label: "dvr",
            radius: crate::volume::support_radius(&base),
            dims: volume.dims,
            bounds,
            samples: (samples_layout, samples),
            layout,
            extra: vec![],
        };
        let core = DvrCaster::new(gpu, tf.table(), look, parts)?;
        let mut stacks = [None, None, None];
        stacks[axis] = Some(core.pipeline(&shader, &format!("{}_dvr_main", scheme.prefix()))?);
        Ok(SchemeRenderer { gpu: gpu.clone(), scheme, base, core, stacks })
    }

    /// The plane stack `camera` looks along (0 x, 1 y, 2 z).
    pub fn stack(camera: &Camera) -> usize {
        stack_for_view(camera.view_direction())
    }

    /// The render log's line for `camera`'s stack.
    pub fn choice_line(&self, camera: &Camera) -> String {
        choice_line(self.scheme, camera.view_direction(), Self::stack(camera))
    }

    /// The fraction of skipping blocks the transfer function leaves transparent.
    pub fn empty_blocks(&self) -> f64 {
        self.core.empty_blocks()
    }

    /// The pipeline of `camera`'s stack, compiled on first use.
    fn pipeline(&mut self, camera: &Camera) -> Result<wgpu::ComputePipeline, RenderError> {
        let axis = Self::stack(camera);
        if let Some(p) = &self.stacks[axis] {
            return Ok(p.clone());
        }
        let shader = compile(&self.gpu, &self.base, self.scheme, axis)?;
        let pipeline = self.core.pipeline(&shader, &format!("{}_dvr_main", self.scheme.prefix()))?;
        self.stacks[axis] = Some(pipeline.clone());
        Ok(pipeline)
    }

    /// Records one frame into `encoder`: the ray caster of the view's
    /// stack, then the image drawn into `target`.
    pub fn encode(
        &mut self,
        encoder: &mut wgpu::CommandEncoder,
        target: &Target<'_>,
        camera: &Camera,
    ) -> Result<(), RenderError> {
        let pipeline = self.pipeline(camera)?;
        self.core.encode(&pipeline, encoder, target, camera)
    }

    /// The CLI's and the bench's frames at `o`'s size and camera (the
    /// look is the renderer's), read back.
    pub(crate) fn timed_frames(&mut self, o: &DvrOptions) -> Result<Frame, RenderError> {
        let camera = Camera { azimuth: o.azimuth, elevation: o.elevation, perspective: o.perspective };
        let pipeline = self.pipeline(&camera)?;
        self.core.timed_frames(&pipeline, o)
    }
}

/// The DVR module of `scheme` on stack `axis`, compiled.
fn compile(gpu: &Gpu, base: &Derivation, scheme: Scheme, axis: usize) -> Result<wgpu::ShaderModule, RenderError> {
    let source = dvr_source(base, scheme, axis)?;
    Ok(gpu.compile(&format!("{}.dvr.wgsl", scheme.prefix()), &source)?)
}
