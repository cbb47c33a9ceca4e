//! Rendering with a PERM cache: a frame of a cache built on a [`DvrScene`]
//! (the bench's and the tests' comparisons with direct evaluation), and
//! the one-shot image of `render --cache perm`, both through the same
//! per-frame core as [`super::PermRenderer`].

use super::{PermCache, PermError, PermRenderer, Quant};
use crate::gpu::Gpu;
use crate::render::dvr::caster::{look_of, CasterParts, DvrCaster};
use crate::render::dvr::transfer::{Preint, Tf1d, TransferFunction};
use crate::render::dvr::{DvrLook, DvrOptions, DvrScene};
use crate::render::iso::Frame;
use crate::render::{Mismatch, RenderError};
use crate::volume::DeviceVolume;

impl PermCache {
    /// Renders with the cache (the same tables it was built for), on the
    /// samples and the skipping blocks of `scene` (whose block edge must
    /// be `o.block`).
    pub fn render(
        &self,
        scene: &DvrScene,
        table: &Tf1d,
        pi: Option<&Preint>,
        o: &DvrOptions,
    ) -> Result<Frame, RenderError> {
        if let Some(t) = self.peel_termination.filter(|&t| o.termination > t) {
            return Err(RenderError::PermPeeled { peeled: t, asked: o.termination });
        }
        if table.entries != self.table || o.step > self.step || pi.is_some() != self.preintegrate {
            return Err(RenderError::BuiltForOther(Mismatch::PermTables {
                built_step: self.step,
                built_preint: self.preintegrate,
                asked_step: o.step,
                asked_preint: pi.is_some(),
            }));
        }
        scene.check_tables(pi, o)?;
        let look = DvrLook { preintegrate: pi.is_some(), ..look_of(o) };
        let parts = CasterParts {
            label: "dvr perm",
            radius: crate::volume::support_radius(scene.d),
            dims: scene.dv.dims,
            bounds: scene.bounds.clone(),
            samples: (scene.bgl_s.clone(), scene.bg_s.clone()),
            layout: self.bgl.clone(),
            extra: self.extras(),
        };
        let mut core = DvrCaster::with_preint(scene.gpu, table.clone(), pi, look, parts)?;
        core.timed_frames(&self.pipeline, o)
    }
}

/// One PERM image (`render --cache perm [--peel]`): the samples uploaded,
/// a [`PermRenderer`] built for `o`'s look, its timed frames.
#[allow(clippy::too_many_arguments)]
pub fn render(
    gpu: &Gpu,
    d: &boxforge::derive::Derivation,
    vol: &crate::volume::LatticeVolume,
    layout: boxforge::emit::Layout,
    tf: &TransferFunction,
    o: &DvrOptions,
    quant: Quant,
    peel: bool,
) -> Result<(Frame, PermCache), PermError> {
    let volume = DeviceVolume::with_options(gpu, vol, layout, &o.volume)?;
    volume.check_filter(d)?;
    let mut renderer = PermRenderer::new(gpu, d, &volume, tf, look_of(o), quant, peel)?;
    let frame = renderer.timed_frames(o)?;
    Ok((frame, renderer.into_cache()))
}
