//! Rendering with a PERM cache.

use super::{PermCache, PermError, Quant};
use crate::gpu::{Gpu, GpuError};
use crate::render::dvr::transfer::{Preint, Tf1d, TransferFunction};
use crate::render::dvr::{Caster, DvrOptions, DvrScene};
use crate::render::iso::Frame;

impl PermCache {
    /// Renders with the cache (the same tables it was built for).
    pub fn render(
        &self,
        scene: &DvrScene,
        table: &Tf1d,
        pi: Option<&Preint>,
        o: &DvrOptions,
    ) -> Result<Frame, GpuError> {
        if let Some(t) = self.peel_termination.filter(|&t| o.termination > t) {
            return Err(GpuError::Runtime(format!(
                "this PERM cache was peeled for rays that stop at opacity {t}; a render with termination {} may reach peeled cells: build one for it",
                o.termination
            )));
        }
        if table.entries != self.table || o.step > self.step || pi.is_some() != self.preintegrate {
            return Err(GpuError::Runtime(format!(
                "this PERM cache was built for another transfer function or for step {} (pre-integrated: {}); build one for these options",
                self.step, self.preintegrate
            )));
        }
        let b = &self.buffers;
        let extra = vec![
            wgpu::BindGroupEntry { binding: 5, resource: self.params.as_entire_binding() },
            wgpu::BindGroupEntry { binding: 6, resource: b[0].as_entire_binding() },
            wgpu::BindGroupEntry { binding: 7, resource: b[1].as_entire_binding() },
            wgpu::BindGroupEntry { binding: 8, resource: wgpu::BindingResource::TextureView(&self.words[0].view) },
            wgpu::BindGroupEntry { binding: 9, resource: wgpu::BindingResource::TextureView(&self.words[1].view) },
        ];
        scene.render_with(table, pi, o, Some(Caster { pipeline: &self.pipeline, bgl: &self.bgl, extra }))
    }
}

/// One PERM image (`render --cache perm [--peel]`): the scene, the cache, a render.
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
    let scene = DvrScene::new(gpu, d, vol, layout, o.block)?;
    let table = tf.table();
    let pi = o.preintegrate.then(|| table.preintegrate(o.step as f64));
    let termination = peel.then_some(o.termination);
    let cache = PermCache::build_peeled(&scene, &table, quant, o.step, o.preintegrate, termination)?;
    let frame = cache.render(&scene, &table, pi.as_ref(), o)?;
    Ok((frame, cache))
}
