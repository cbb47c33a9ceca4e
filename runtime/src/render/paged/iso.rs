//! Isosurfaces out of core: the fixed-step walk of `templates/raycast.wgsl.j2`
//! (`paged`), suspended where a ray needs a brick the pool lacks and resumed
//! in the next pass, over the shared [`BrickPool`].

use super::pool::{BrickPool, Reserve};
use super::{occupied, PagedOptions, PagedStats};
use crate::gpu::binding::{entries_for, layout_entries_from};
use crate::gpu::Gpu;
use crate::memory::trace_memory;
use crate::render::blocks::{self, SkipMap};
use crate::render::iso::{ray_params_for, Frame, RayParams, RenderOptions};
use crate::render::RenderError;
use crate::volume::BrickSource;
use boxforge::derive::Derivation;
use boxforge::emit::{emit, EmitOptions, Layout};

/// Device bytes of the iso caster besides the pool: per block its bounds
/// with the distance map, per pixel image, depth and resume state.
const RESERVE: Reserve = Reserve { per_block: 12, per_pixel: 4 + 4 + 16, fixed: 0 };

/// An isosurface of a [`BrickSource`] rendered out of core (see the module documentation).
pub struct PagedIsoRenderer {
    gpu: Gpu,
    options: PagedOptions,
    radius: usize,
    pool: BrickPool,
    pipeline: wgpu::ComputePipeline,
    bindings: Vec<boxforge::validate::Binding>,
    caster_layout: wgpu::BindGroupLayout,
    blocks: wgpu::Buffer,
    occupied_bricks: usize,
    empty_blocks: f64,
}

impl PagedIsoRenderer {
    /// Reads `source` once, brick row by brick row, for the block bounds,
    /// then sizes the pool to the budget (nothing is uploaded yet).
    pub fn new(
        gpu: &Gpu,
        d: &Derivation,
        source: &dyn BrickSource,
        options: PagedOptions,
        progress: &dyn Fn(usize, usize),
    ) -> Result<PagedIsoRenderer, RenderError> {
        let name = d.filter.name.clone();
        let (pool, bounds) = BrickPool::new(gpu, d, source, &options, RESERVE, progress)?;
        let options = PagedOptions { block: pool.block as i32, ..options };
        // The block tables are only needed until their device copy exists:
        // drop them here and hand their memory back before the pool fills.
        let (blocks_buf, empty_blocks, occupied_bricks) = {
            let iso = options.iso;
            let empty: Vec<u32> = bounds.iter().map(|b| (iso < b[0] || iso > b[1]) as u32).collect();
            let empty_blocks = empty.iter().filter(|&&e| e != 0).count() as f64 / empty.len().max(1) as f64;
            let grid = blocks::blocks_per_axis(pool.dims, options.block);
            let occupied_bricks = occupied(&empty, grid, pool.bricks, pool.shape.edge / pool.block);
            let (distances, _) = blocks::skip_map(&empty, grid, 0, SkipMap::Distance);
            drop(empty);
            let table = blocks::bounds_with_distances(&bounds, &distances);
            drop((bounds, distances));
            let buf = blocks::upload(gpu, "paged blocks", &table);
            (buf, empty_blocks, occupied_bricks)
        };
        gpu.queue.submit([]);
        gpu.wait()?;
        crate::memory::release_free_heap();
        trace_memory("skip map");
        let module = EmitOptions {
            layout: Layout::Bricked,
            samples: pool.map,
            texels: pool.format.texels(),
            command: "boxforge_runtime::render::paged::PagedIsoRenderer".into(),
            kernels: false,
            ..Default::default()
        };
        let m = emit(d, &module)?;
        let source_text = format!("{}\n{}", m.source, crate::render::iso::template::paged_template(&name));
        let shader = gpu.compile(&format!("{name}.paged.wgsl"), &source_text)?;
        let bindings = gpu.bindings_of(&source_text)?;
        let caster_layout = gpu.device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("paged raycast"),
            entries: &layout_entries_from(&bindings, 1)?,
        });
        let pipeline = gpu.pipeline(
            "paged raycast",
            &shader,
            &[&pool.samples_layout, &caster_layout],
            &format!("{name}_raycast_main"),
        )?;
        trace_memory("pool");
        Ok(PagedIsoRenderer {
            gpu: gpu.clone(),
            options,
            radius: crate::volume::support_radius(d),
            pool,
            pipeline,
            bindings,
            caster_layout,
            blocks: blocks_buf,
            occupied_bricks,
            empty_blocks,
        })
    }

    /// Whether the block bounds were read from the bounds cache (not
    /// computed by a pass over the source).
    pub fn bounds_cached(&self) -> bool {
        self.pool.bounds_cached
    }

    /// The sample map the pool's texels are read with.
    pub fn sample_map(&self) -> boxforge::emit::SampleMap {
        self.pool.map
    }

    /// One frame: passes until every ray is done. `o` gives the camera and
    /// image size (its iso, step and block must be this renderer's).
    pub fn render(&mut self, source: &dyn BrickSource, o: &RenderOptions) -> Result<(Frame, PagedStats), RenderError> {
        let pixels = super::check_pixels(o.width, o.height, self.options.max_pixels)?;
        let start = std::time::Instant::now();
        let gpu = &self.gpu;
        let o = RenderOptions {
            iso: self.options.iso,
            step: self.options.step,
            block: self.options.block,
            skip: true,
            skip_map: SkipMap::Distance,
            ..o.clone()
        };
        let params: RayParams = ray_params_for(self.radius, self.pool.dims, &o);
        let params_buf = gpu.uniform_buffer("paged params", bytemuck::bytes_of(&params));
        let n = pixels as usize;
        let image = gpu.storage_buffer("paged image", &vec![0u8; n * 4], true);
        let depth = gpu.storage_buffer("paged depth", &vec![0u8; n * 4], true);
        let resume = gpu.storage_buffer("paged resume", &vec![0u8; n * 16], true);
        let resources =
            [(0, &params_buf), (1, &image), (2, &self.blocks), (3, &depth), (8, &resume), (9, &self.pool.requests)];
        let entries = entries_for(&self.bindings, 1, &resources);
        let caster = gpu.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("paged raycast"),
            layout: &self.caster_layout,
            entries: &entries,
        });
        let groups = (o.width.div_ceil(8), o.height.div_ceil(8), 1);
        // The samples group is a handle: a clone lets the pool run the passes.
        let (pipeline, samples) = (&self.pipeline, self.pool.samples.clone());
        let mut stats = self
            .pool
            .run_passes(source, || Ok(gpu.dispatch("paged raycast", pipeline, &[&samples, &caster], groups)?))?;
        let words: Vec<u32> = bytemuck::cast_slice(&gpu.read_buffer(&image)?).to_vec();
        let rgba = bytemuck::cast_slice(&words).to_vec();
        let ms = start.elapsed().as_secs_f64() * 1e3;
        stats.occupied_bricks = self.occupied_bricks;
        stats.device_bytes = self.pool.device_bytes(&self.options, RESERVE, pixels);
        stats.ms = ms;
        let frame = Frame {
            width: o.width,
            height: o.height,
            rgba,
            ms_per_frame: ms,
            empty_blocks: self.empty_blocks,
            skip_map: None,
        };
        Ok((frame, stats))
    }
}
