//! A volume on the device ready for DVR, and its ray caster.

use super::{dvr_params, empty_flags, skip_distances, widen_bounds, DvrOptions, DvrParams};
use crate::gpu::binding::storage_entry;
use crate::gpu::Gpu;
use crate::render::blocks::block_bounds;
use crate::render::dvr::transfer::{Preint, Tf1d, TransferFunction};
use crate::render::iso::Frame;
use crate::render::{Mismatch, RenderError};
use crate::volume::{DeviceVolume, LatticeVolume, VolumeOptions};
use boxforge::derive::Derivation;
use boxforge::emit::Layout;

/// A volume ready for DVR on the device: the compiled pipeline, the samples
/// and the block [min, max] grid (computed once; each [`DvrScene::render`]
/// takes a transfer function and options).
pub struct DvrScene<'a> {
    pub(crate) gpu: &'a Gpu,
    pub(crate) d: &'a Derivation,
    pub(crate) vol: &'a LatticeVolume,
    block: i32,
    pipeline: wgpu::ComputePipeline,
    bgl_rc: wgpu::BindGroupLayout,
    pub(crate) bgl_s: wgpu::BindGroupLayout,
    pub(crate) bg_s: wgpu::BindGroup,
    pub(crate) dv: DeviceVolume,
    /// [min, max] of the spline over each block (x fastest).
    pub bounds: Vec<[f32; 2]>,
    /// The curvature transfer function's radius the shader was built with.
    curvature: Option<f32>,
}

impl<'a> DvrScene<'a> {
    /// Compiles the shader, uploads the samples and bounds every block of
    /// `block`^3 cubes with the emitted min/max kernel.
    pub fn new(
        gpu: &'a Gpu,
        d: &'a Derivation,
        vol: &'a LatticeVolume,
        layout: Layout,
        block: i32,
    ) -> Result<DvrScene<'a>, RenderError> {
        Self::with_volume(gpu, d, vol, layout, block, &VolumeOptions::default())
    }

    /// [`DvrScene::new`] with the samples stored as `volume` says (a
    /// compact format, a brick shape): the module is emitted for them.
    pub fn with_volume(
        gpu: &'a Gpu,
        d: &'a Derivation,
        vol: &'a LatticeVolume,
        layout: Layout,
        block: i32,
        volume: &VolumeOptions,
    ) -> Result<DvrScene<'a>, RenderError> {
        Self::with_curvature(gpu, d, vol, layout, block, volume, None)
    }

    /// [`DvrScene::with_volume`] with the curvature transfer function of
    /// radius `curvature` cells (`DvrOptions::curvature`; None: without):
    /// the ray caster samples `<f>_eval_hessian` and colours by (k1, k2).
    pub fn with_curvature(
        gpu: &'a Gpu,
        d: &'a Derivation,
        vol: &'a LatticeVolume,
        layout: Layout,
        block: i32,
        volume: &VolumeOptions,
        curvature: Option<f32>,
    ) -> Result<DvrScene<'a>, RenderError> {
        if let Some(radius) = curvature {
            super::check_curvature_tf(d, radius)?;
        }
        let name = &d.filter.name;
        let dv = DeviceVolume::with_options(gpu, vol, layout, volume)?;
        dv.check_filter(d)?;
        let module = super::filter_module_with(d, &dv.emit_options(super::DVR_COMMAND))?;
        let source = format!("{module}\n{}", super::dvr_template_curvature(name, false, false, curvature));
        let mut scene =
            Self::with_device_volume(gpu, d, vol, dv, block, Custom { name, source: &source, minmax: name, reach: 0 })?;
        scene.curvature = curvature;
        Ok(scene)
    }

    /// A scene whose ray caster evaluates a function other than `d`'s
    /// emitted one (hand-written schemes built on top of DVR): its
    /// module `source` (with `d`'s emitted module inside) defines
    /// `<name>_eval_grad` and the DVR template for `name`; blocks are
    /// bounded by `d`'s min/max kernel `<minmax>_minmax_main`, per cell and
    /// widened by `reach` cells when the function reaches further than
    /// `d`'s support ([`widen_bounds`]).
    #[cfg(feature = "references")]
    pub(crate) fn with_source(
        gpu: &'a Gpu,
        d: &'a Derivation,
        vol: &'a LatticeVolume,
        layout: Layout,
        block: i32,
        custom: Custom<'_>,
    ) -> Result<DvrScene<'a>, RenderError> {
        let dv = DeviceVolume::new(gpu, vol, layout)?;
        Self::with_device_volume(gpu, d, vol, dv, block, custom)
    }

    /// [`DvrScene::with_source`] over samples already on the device.
    fn with_device_volume(
        gpu: &'a Gpu,
        d: &'a Derivation,
        vol: &'a LatticeVolume,
        dv: DeviceVolume,
        block: i32,
        custom: Custom<'_>,
    ) -> Result<DvrScene<'a>, RenderError> {
        let name = custom.name;
        let shader = gpu.compile(&format!("{name}.dvr.wgsl"), custom.source)?;
        let dev = &gpu.device;
        let bounds = if custom.reach > 0 {
            let cells = block_bounds(gpu, &shader, custom.minmax, &dv, vol.dims, 1)?;
            widen_bounds(&cells, vol.dims, block as usize, custom.reach)
        } else {
            block_bounds(gpu, &shader, custom.minmax, &dv, vol.dims, block)?
        };

        let bgl_s = dev.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("samples"),
            entries: &dv.layout_entries(0, wgpu::ShaderStages::COMPUTE),
        });
        let bgl_rc = dev.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("dvr"),
            entries: &caster_entries(gpu),
        });
        let pipeline = gpu.pipeline("dvr", &shader, &[&bgl_s, &bgl_rc], &format!("{name}_dvr_main"))?;
        let bg_s = dev.create_bind_group(&wgpu::BindGroupDescriptor {
            label: None,
            layout: &bgl_s,
            entries: &dv.bind_entries(0),
        });
        Ok(DvrScene { gpu, d, vol, block, pipeline, bgl_rc, bgl_s, bg_s, dv, bounds, curvature: None })
    }

    /// Refuses options that this scene's block grid, or the pre-integration
    /// table `pi`, was not built for (the checks of [`DvrScene::render_tables`]
    /// and of the PERM cache's render on a scene).
    pub(crate) fn check_tables(&self, pi: Option<&Preint>, o: &DvrOptions) -> Result<(), RenderError> {
        if o.block != self.block {
            return Err(RenderError::BuiltForOther(Mismatch::BlockEdge { built: self.block, asked: o.block }));
        }
        if let Some(p) = pi.filter(|p| p.step != o.step) {
            return Err(RenderError::BuiltForOther(Mismatch::PreintStep { built: p.step, asked: o.step }));
        }
        Ok(())
    }

    /// Renders one image (a warm-up frame, then `o.frames` timed frames);
    /// `empty_blocks` is the fraction of blocks the transfer function leaves
    /// transparent (fewer are skipped: see `skip::skip_flags`).
    pub fn render(&self, tf: &TransferFunction, o: &DvrOptions) -> Result<Frame, RenderError> {
        let table = tf.table();
        let pi = if o.preintegrate { Some(table.preintegrate(o.step as f64)) } else { None };
        self.render_tables(&table, pi.as_ref(), o)
    }

    /// [`DvrScene::render`] with tables already built (the pre-integration
    /// table must be for `o.step`; None renders without pre-integration).
    pub fn render_tables(&self, table: &Tf1d, pi: Option<&Preint>, o: &DvrOptions) -> Result<Frame, RenderError> {
        let (gpu, dev) = (self.gpu, &self.gpu.device);
        self.check_tables(pi, o)?;
        if o.curvature != self.curvature {
            return Err(RenderError::BuiltForOther(Mismatch::Curvature { built: self.curvature, asked: o.curvature }));
        }
        let o = &DvrOptions { preintegrate: pi.is_some(), ..o.clone() };
        let pi_size = pi.map_or(2, |p| p.size);
        let params = dvr_params(self.d, self.vol, table, pi_size, o);
        let empty_blocks = empty_flags(&self.bounds, table);
        let empty = empty_blocks.iter().filter(|&&f| f != 0).count() as f64 / empty_blocks.len().max(1) as f64;
        let radius = (o.step / self.block as f32).ceil() as i32;
        let (flags, skip_map) =
            skip_distances(&empty_blocks, [params.blocks[0], params.blocks[1], params.blocks[2]], radius, o.skip_map);
        let pi_entries: Vec<[f32; 4]> = pi.map_or_else(|| vec![[0.0; 4]; 4], |p| p.entries.clone());
        let pixels = (o.width * o.height) as usize;
        let params_buf = gpu.uniform_buffer("dvr params", bytemuck::bytes_of(&params));
        let image = gpu.storage_buffer("dvr image", &vec![0u8; pixels * 4], true);
        let flags_buf = gpu.storage_buffer("dvr flags", bytemuck::cast_slice(&flags), false);
        let tf_buf = gpu.storage_buffer("dvr tf", bytemuck::cast_slice(&table.entries), false);
        let pi_buf = gpu.storage_buffer("dvr preint", bytemuck::cast_slice(&pi_entries), false);
        let entries = [
            wgpu::BindGroupEntry { binding: 0, resource: params_buf.as_entire_binding() },
            wgpu::BindGroupEntry { binding: 1, resource: image.as_entire_binding() },
            wgpu::BindGroupEntry { binding: 2, resource: flags_buf.as_entire_binding() },
            wgpu::BindGroupEntry { binding: 3, resource: tf_buf.as_entire_binding() },
            wgpu::BindGroupEntry { binding: 4, resource: pi_buf.as_entire_binding() },
        ];
        let bg_rc =
            dev.create_bind_group(&wgpu::BindGroupDescriptor { label: None, layout: &self.bgl_rc, entries: &entries });
        let times = crate::gpu::timing::timed_banded_frames(
            gpu,
            &self.pipeline,
            [&self.bg_s, &bg_rc],
            (&params_buf, params, |p: &mut DvrParams, y0| p.image[3] = y0 as i32),
            (o.width, o.height, if o.progress { 16 } else { o.height }),
            ("dvr", "volume rendering rows", o.progress),
            o.frames,
        )?;
        let words: Vec<u32> = bytemuck::cast_slice(&gpu.read_buffer(&image)?).to_vec();
        let rgba = words.iter().flat_map(|w| w.to_le_bytes()).collect();
        let ms = if times.is_empty() { f64::NAN } else { times[times.len() / 2] };
        Ok(Frame {
            width: o.width,
            height: o.height,
            rgba,
            ms_per_frame: ms,
            empty_blocks: empty,
            skip_map: Some(skip_map),
        })
    }
}

/// The group-1 layout entries of the ray caster (bindings 0 to 4; the
/// parameters where `gpu` keeps them, [`crate::gpu::params`]).
pub(crate) fn caster_entries(gpu: &Gpu) -> Vec<wgpu::BindGroupLayoutEntry> {
    vec![
        gpu.params_entry(0),
        storage_entry(1, false),
        storage_entry(2, true),
        storage_entry(3, true),
        storage_entry(4, true),
    ]
}

/// The ray-cast function of [`DvrScene::with_source`].
pub(crate) struct Custom<'s> {
    /// Prefix of `<name>_eval_grad` and of the DVR template's names.
    pub name: &'s str,
    /// The whole module: evaluation, min/max kernel and DVR template.
    pub source: &'s str,
    /// Prefix of the min/max kernel that bounds the blocks.
    pub minmax: &'s str,
    /// Cells beyond a block whose values the function reaches (0: the
    /// blocks are bounded directly by the min/max kernel).
    pub reach: usize,
}

/// One DVR image on the device (a [`DvrScene`] for a single render).
pub fn render(
    gpu: &Gpu,
    d: &Derivation,
    vol: &LatticeVolume,
    layout: Layout,
    tf: &TransferFunction,
    o: &DvrOptions,
) -> Result<Frame, RenderError> {
    DvrScene::with_curvature(gpu, d, vol, layout, o.block, &o.volume, o.curvature)?.render(tf, o)
}
