//! Direct volume rendering out of core: the DVR ray caster of
//! `templates/dvr.wgsl.j2` (`paged`) over the shared [`BrickPool`]. Before
//! each evaluation a ray checks that the brick of its point is in the pool;
//! if not it saves its segment, colour and opacity and stops, and the next
//! pass resumes it there. The segments, the transfer-function-aware
//! skipping (flags from the pool's block bounds) and the compositing are
//! the in-core caster's, so the frame equals the in-core frame, and bricks
//! only skipped segments cross are never uploaded.

use super::pool::{BrickPool, Reserve};
use super::{check_pixels, occupied, PagedOptions, PagedStats};
use crate::gpu::binding::layout_entries_from;
use crate::gpu::Gpu;
use crate::memory::trace_memory;
use crate::render::blocks::blocks_per_axis;
use crate::render::dvr::caster::{CasterParts, DvrCaster, Extra};
use crate::render::dvr::transfer::Tf1d;
use crate::render::dvr::{empty_flags, DvrLook, DvrOptions};
use crate::render::iso::Frame;
use crate::render::RenderError;
use crate::volume::BrickSource;
use boxforge::derive::Derivation;
use boxforge::emit::{emit, EmitOptions, Layout};

/// Bytes of a suspended ray's state: colour and opacity, the front sample,
/// (segment, front loaded, phase).
const RESUME_BYTES: u64 = 3 * 16;

/// A direct volume rendering of a [`BrickSource`] out of core (see the module documentation).
pub struct PagedDvrRenderer {
    gpu: Gpu,
    options: PagedOptions,
    reserve: Reserve,
    pool: BrickPool,
    caster: DvrCaster,
    pipeline: wgpu::ComputePipeline,
    resume: wgpu::Buffer,
    occupied_bricks: usize,
}

impl PagedDvrRenderer {
    /// Reads `source` once, brick row by brick row, for the block bounds
    /// (blocks of `look.block` cubes, coarser when the budget needs it),
    /// flags the blocks `table` leaves transparent, and sizes the pool to
    /// the budget (nothing is uploaded yet). `options.iso` and
    /// `options.step` are the isosurface's and unused here: the look has
    /// the step.
    pub fn new(
        gpu: &Gpu,
        d: &Derivation,
        source: &dyn BrickSource,
        table: Tf1d,
        look: DvrLook,
        options: PagedOptions,
        progress: &dyn Fn(usize, usize),
    ) -> Result<PagedDvrRenderer, RenderError> {
        if look.curvature.is_some() {
            return Err(RenderError::PagedCurvature);
        }
        let name = d.filter.name.clone();
        let pi = look.preintegrate.then(|| table.preintegrate(look.step as f64));
        let reserve = Reserve {
            per_block: 4,
            per_pixel: 4 + RESUME_BYTES,
            fixed: (table.entries.len() + pi.as_ref().map_or(4, |p| p.entries.len())) as u64 * 16
                + std::mem::size_of::<crate::render::dvr::DvrParams>() as u64,
        };
        let options = PagedOptions { block: look.block, ..options };
        let (pool, bounds) = BrickPool::new(gpu, d, source, &options, reserve, progress)?;
        let options = PagedOptions { block: pool.block as i32, ..options };
        let look = DvrLook { block: options.block, ..look };
        let grid = blocks_per_axis(pool.dims, options.block);
        let occupied_bricks = occupied(&empty_flags(&bounds, &table), grid, pool.bricks, pool.shape.edge / pool.block);
        let module = EmitOptions {
            layout: Layout::Bricked,
            samples: pool.map,
            texels: pool.format.texels(),
            command: "boxforge_runtime::render::paged::PagedDvrRenderer".into(),
            kernels: false,
            ..Default::default()
        };
        let m = emit(d, &module)?;
        let text = format!("{}\n{}", m.source, crate::render::dvr::dvr_template_paged(&name));
        let label = format!("{name}.paged_dvr.wgsl");
        let shader = gpu.compile(&label, &text)?;
        let bindings = gpu.bindings_of(&text)?;
        let layout = gpu.device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("paged dvr"),
            entries: &layout_entries_from(&bindings, 1)?,
        });
        let resume =
            gpu.storage_buffer("paged dvr resume", &vec![0u8; (options.max_pixels * RESUME_BYTES) as usize], true);
        let parts = CasterParts {
            label: "paged dvr",
            radius: crate::volume::support_radius(d),
            dims: pool.dims,
            bounds,
            samples: (pool.samples_layout.clone(), pool.samples.clone()),
            layout,
            extra: vec![(8, Extra::Buffer(resume.clone())), (9, Extra::Buffer(pool.requests.clone()))],
        };
        let caster = DvrCaster::with_preint(gpu, table, pi.as_ref(), look, parts)?;
        drop(pi);
        crate::memory::release_free_heap();
        let pipeline = caster.pipeline(&shader, &format!("{name}_dvr_main"))?;
        trace_memory("pool");
        Ok(PagedDvrRenderer { gpu: gpu.clone(), options, reserve, pool, caster, pipeline, resume, occupied_bricks })
    }

    /// Whether the block bounds were read from the bounds cache.
    pub fn bounds_cached(&self) -> bool {
        self.pool.bounds_cached
    }

    /// One frame: passes until every ray is done. `o` gives the camera and
    /// image size; the look (step, block, skipping, pre-integration,
    /// termination) is this renderer's.
    pub fn render(&mut self, source: &dyn BrickSource, o: &DvrOptions) -> Result<(Frame, PagedStats), RenderError> {
        let pixels = check_pixels(o.width, o.height, self.options.max_pixels)?;
        let start = std::time::Instant::now();
        self.caster.prepare(o)?;
        // Every ray starts from the beginning.
        let mut enc =
            self.gpu.device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("paged dvr") });
        enc.clear_buffer(&self.resume, 0, Some(pixels * RESUME_BYTES));
        self.gpu.queue.submit([enc.finish()]);
        let (caster, pipeline) = (&self.caster, &self.pipeline);
        let mut stats = self.pool.run_passes(source, || caster.dispatch_image(pipeline))?;
        let ms = start.elapsed().as_secs_f64() * 1e3;
        let frame = self.caster.read_image(ms)?;
        stats.occupied_bricks = self.occupied_bricks;
        stats.device_bytes = self.pool.device_bytes(&self.options, self.reserve, pixels);
        stats.ms = ms;
        Ok((frame, stats))
    }
}
