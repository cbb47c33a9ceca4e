//! The PERM renderer a host drives frame by frame: the cache is built once
//! for a transfer function and look (preprocessing on the device, the
//! lookup's pipeline compiled, the skipping flags uploaded), then
//! [`PermRenderer::encode`] records a frame into the host's encoder and
//! colour target. The cache is view-independent (peeling included: it
//! holds for every view from outside the volume), so a frame writes only
//! the ray parameters; frames after the first at one size create no
//! buffer, texture or shader module.

use super::build::On;
use super::{PermCache, PermError, Quant};
use crate::gpu::Gpu;
use crate::render::blocks::block_bounds;
use crate::render::camera::{Camera, Target};
use crate::render::dvr::caster::{CasterParts, DvrCaster};
use crate::render::dvr::transfer::TransferFunction;
use crate::render::dvr::{DvrLook, DvrOptions};
use crate::render::iso::Frame;
use crate::render::RenderError;
use crate::volume::DeviceVolume;
use boxforge::derive::Derivation;

/// A volume rendering through a PERM cache of one volume, filter and
/// transfer function.
pub struct PermRenderer {
    core: DvrCaster,
    pipeline: wgpu::ComputePipeline,
    cache: PermCache,
}

impl PermRenderer {
    /// Builds the cache of `d` on `volume` (shared: it stays the caller's)
    /// at resolutions `quant` for `tf` and `look` (pre-integrated segments
    /// of `look.step` dilate the candidates; `peel` drops the cells no ray
    /// reaches before `look.termination`), and the lookup's ray caster.
    pub fn new(
        gpu: &Gpu,
        d: &Derivation,
        volume: &DeviceVolume,
        tf: &TransferFunction,
        look: DvrLook,
        quant: Quant,
        peel: bool,
    ) -> Result<PermRenderer, PermError> {
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
        let table = tf.table();
        let on = On { gpu, d, volume, samples: (&samples_layout, &samples) };
        let termination = peel.then_some(look.termination);
        let (cache, build) = PermCache::build_on(on, &table, quant, look.step, look.preintegrate, termination)?;
        // The skipping blocks, by the filter's min/max kernel in the preprocessing module.
        let bounds = block_bounds(gpu, &build, &d.filter.name, volume, volume.dims, look.block)?;
        let parts = CasterParts {
            label: "dvr perm",
            radius: crate::volume::support_radius(d),
            dims: volume.dims,
            bounds,
            samples: (samples_layout, samples),
            layout: cache.bgl.clone(),
            extra: cache.extras(),
        };
        let core = DvrCaster::new(gpu, table, look, parts)?;
        Ok(PermRenderer { pipeline: cache.pipeline.clone(), core, cache })
    }

    /// The cache: its counts, memory, preprocessing time and peeling.
    pub fn cache(&self) -> &PermCache {
        &self.cache
    }

    /// The cache, the renderer done with.
    pub fn into_cache(self) -> PermCache {
        self.cache
    }

    /// The fraction of skipping blocks the transfer function leaves transparent.
    pub fn empty_blocks(&self) -> f64 {
        self.core.empty_blocks()
    }

    /// Records one frame into `encoder`: the lookup's ray caster, then the
    /// image drawn into `target`.
    pub fn encode(
        &mut self,
        encoder: &mut wgpu::CommandEncoder,
        target: &Target<'_>,
        camera: &Camera,
    ) -> Result<(), RenderError> {
        self.core.encode(&self.pipeline, encoder, target, camera)
    }

    /// The CLI's frames at `o`'s size and camera (the look is the
    /// renderer's), read back.
    pub(crate) fn timed_frames(&mut self, o: &DvrOptions) -> Result<Frame, RenderError> {
        self.core.timed_frames(&self.pipeline, o)
    }
}
