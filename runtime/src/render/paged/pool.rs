//! The core every out-of-core renderer shares: the block bounds of the
//! source (computed brick row by brick row, or read from the bounds cache),
//! a pool texture of as many brick slots as the budget leaves, the page
//! table, the request bits a pass's rays set for the bricks they lack, and
//! the pass loop (dispatch, read the requests, upload the bricks, again)
//! that [`super::PagedIsoRenderer`] and [`super::PagedDvrRenderer`] run with
//! their own ray casters. The WGSL side is `templates/paged.wgsl.j2`.

use super::bounds;
use super::cache::{requested_bricks, BrickCache};
use super::{PagedOptions, PagedStats, MAX_PASSES};
use crate::gpu::Gpu;
use crate::memory::trace_memory;
use crate::render::RenderError;
use crate::volume::{slot_grid, BrickShape, BrickSource, SampleFormat};
use boxforge::derive::Derivation;
use boxforge::emit::SampleMap;

/// What a renderer keeps on the device besides the pool, the page table
/// and the request bits: bytes per block of its bounds table, per pixel of
/// its largest image, and once.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Reserve {
    pub per_block: u64,
    pub per_pixel: u64,
    pub fixed: u64,
}

/// See the module documentation.
pub(crate) struct BrickPool {
    gpu: Gpu,
    pub shape: BrickShape,
    pub dims: [usize; 3],
    pub bricks: [usize; 3],
    pub map: SampleMap,
    pub format: SampleFormat,
    /// The block edge the bounds were computed for (the budget may have
    /// coarsened the requested one).
    pub block: usize,
    /// Kept with the bind group that reads it.
    _pool: wgpu::Texture,
    pages: wgpu::Texture,
    /// Group 0 of the paged ray casters: pool, brick uniform, page table.
    pub samples_layout: wgpu::BindGroupLayout,
    pub samples: wgpu::BindGroup,
    /// One bit per brick, then the count of rays waiting.
    pub requests: wgpu::Buffer,
    words: usize,
    pub cache: BrickCache,
    /// Device bytes of everything but the pool.
    pub fixed_bytes: u64,
    pub pool_bytes: u64,
    /// Whether the block bounds came from [`PagedOptions::bounds_cache`].
    pub bounds_cached: bool,
    /// Passes rendered so far, over all frames (the cache's clock).
    pass_stamp: u64,
}

impl BrickPool {
    /// Picks the block edge (doubling from `options.block` until the
    /// renderer's bounds table fits one storage binding and an eighth of the
    /// budget), reads `source` once for the block bounds (or the bounds
    /// cache), and sizes the pool to what the budget leaves after `reserve`
    /// (nothing is uploaded yet). Returns the pool and the bounds, one
    /// [min, max] per block of `pool.block` cubes, x fastest.
    pub fn new(
        gpu: &Gpu,
        d: &Derivation,
        source: &dyn BrickSource,
        options: &PagedOptions,
        reserve: Reserve,
        progress: &dyn Fn(usize, usize),
    ) -> Result<(BrickPool, Vec<[f32; 2]>), RenderError> {
        crate::memory::map_large_allocations();
        let dims = source.dims();
        let period = bounds::lattice_period(source.lattice());
        let binding_limit = gpu.limits().max_storage_buffer_binding_size;
        let mut block = options.block.max(1) as usize;
        let table_bytes = |b: usize| dims.iter().map(|n| n.div_ceil(b) as u64).product::<u64>() * reserve.per_block;
        while 2 * block <= options.brick
            && options.brick.is_multiple_of(2 * block)
            && table_bytes(block) > binding_limit.min(options.budget / 8)
        {
            block *= 2;
        }
        if options.brick == 0 || !options.brick.is_multiple_of(block) || !options.brick.is_multiple_of(period) {
            return Err(RenderError::BrickEdge { brick: options.brick, block, period });
        }
        let format = options.format;
        // A slot is uploaded on its own: with four u8 samples a texel its
        // edge must be whole texels, so the halo grows (by at most 2) until
        // it is (the fetches then read a little less far than the slot holds).
        let reach = boxforge::emit::bricks::brick_halo(d);
        let halo = (reach..).find(|h| (options.brick + 2 * h).is_multiple_of(format.per_texel())).unwrap_or(reach);
        let shape = BrickShape { edge: options.brick, halo };
        let slot = shape.slot();
        let bricks = dims.map(|n| n.div_ceil(shape.edge));
        let nbricks = bricks.iter().product::<usize>();
        let nblocks: usize = dims.iter().map(|n| n.div_ceil(block)).product();
        let slot_bytes = (slot * slot * slot * format.bytes()) as u64;
        let words = nbricks.div_ceil(32) + 1;
        // Everything but the pool: page table, request bits, the renderer's
        // block table and image buffers.
        let fixed_bytes = nbricks as u64 * 4
            + words as u64 * 4
            + nblocks as u64 * reserve.per_block
            + options.max_pixels * reserve.per_pixel
            + reserve.fixed
            + 1024;
        let need = fixed_bytes + 8 * slot_bytes;
        if options.budget < need {
            return Err(RenderError::BudgetTooSmall {
                budget: options.budget,
                fixed: fixed_bytes,
                slot_bytes,
                slot,
                format: format.name(),
                need,
            });
        }
        let max_edge = options.max_pool_edge.unwrap_or(gpu.limits().max_texture_dimension_3d as usize);
        let by_budget = ((options.budget - fixed_bytes) / slot_bytes) as usize;
        let per_axis = (max_edge / slot).min(boxforge::emit::bricks::max_slots_per_axis(3));
        // Every slot of the pool texture counts against the budget: a grid
        // for the bricks when they all fit, else the largest grid that does.
        let slots = slot_grid(nbricks, slot, max_edge)
            .filter(|g| g.iter().product::<usize>() <= by_budget)
            .unwrap_or_else(|| {
                let sx = per_axis.min(by_budget);
                let sy = per_axis.min(by_budget / sx.max(1));
                let sz = per_axis.min(by_budget / (sx * sy).max(1));
                [sx, sy, sz]
            });
        let capacity = slots.iter().product::<usize>();
        if capacity < 8.min(nbricks) {
            return Err(RenderError::PoolEdge { max_edge, capacity, slot });
        }
        trace_memory("start");
        // Only the normalized formats need the range (a pass over the source).
        let map = match format {
            SampleFormat::U8 | SampleFormat::U16 => {
                let (lo, hi) = source.sample_range()?;
                format.map_for(lo, hi)
            }
            SampleFormat::F32 | SampleFormat::F16 => SampleMap::IDENTITY,
        };
        trace_memory("range");
        // Preprocessing: a slab texture of at most a quarter of the budget
        // on the device (destroyed before the pool is allocated), filled one row of
        // bricks at a time from the host. Few large dispatches also matter
        // on lavapipe, which keeps about 1.3 MB per dispatch of bcc7's
        // min/max kernel (measured: 64 dispatches +83 MB, 256 +330 MB).
        let max_texels = ((options.budget / 4) as usize / format.bytes()).max(slot * slot * slot * 4);
        let cache_file = options.bounds_cache.as_deref().and_then(|dir| {
            let key = format!(
                "{}|{}|{:?}|{}|{:?}|{:?}|{}|{}|{}",
                source.identity()?,
                d.filter.name,
                d.facts.directions,
                d.filter.lattice.name,
                format,
                map,
                shape.edge,
                shape.halo,
                block
            );
            Some(bounds::BoundsCache::new(dir, key))
        });
        let cached = cache_file.as_ref().and_then(|c| c.read(nblocks));
        let bounds_cached = cached.is_some();
        let bounds = match cached {
            Some(b) => b,
            None => {
                let b = bounds::brick_row_bounds(gpu, d, source, format, map, shape.edge, block, max_texels, progress)?;
                if let Some(c) = &cache_file {
                    if let Err(e) = c.write(&b) {
                        eprintln!("note: the block bounds were not cached ({e}); the next render computes them again");
                    }
                }
                b
            }
        };
        trace_memory("bounds");
        let dev = &gpu.device;
        let pool_size = slots.map(|s| (s * slot) as u32);
        let pool = gpu.sampled_texture_3d(
            "brick pool",
            format.texture_size(pool_size.map(|n| n as usize)),
            format.texture_format(),
        );
        let pages = gpu.sampled_texture_3d("page table", bricks.map(|n| n as u32), wgpu::TextureFormat::R32Uint);
        let uniform: [i32; 8] = [
            dims[0] as i32,
            dims[1] as i32,
            dims[2] as i32,
            shape.edge as i32,
            bricks[0] as i32,
            bricks[1] as i32,
            bricks[2] as i32,
            shape.halo as i32,
        ];
        let bricks_buf = gpu.uniform_buffer("bricks", bytemuck::cast_slice(&uniform));
        let samples_layout = dev.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("paged samples"),
            entries: &[
                crate::gpu::binding::samples_texture_entry(0, wgpu::ShaderStages::COMPUTE, format.texels(), false),
                crate::gpu::binding::uniform_entry(1),
                crate::gpu::binding::texture_entry(2),
            ],
        });
        let pool_view = pool.create_view(&Default::default());
        let pages_view = pages.create_view(&Default::default());
        let samples = dev.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("paged samples"),
            layout: &samples_layout,
            entries: &[
                wgpu::BindGroupEntry { binding: 0, resource: wgpu::BindingResource::TextureView(&pool_view) },
                wgpu::BindGroupEntry { binding: 1, resource: bricks_buf.as_entire_binding() },
                wgpu::BindGroupEntry { binding: 2, resource: wgpu::BindingResource::TextureView(&pages_view) },
            ],
        });
        let requests = gpu.storage_buffer("paged requests", &vec![0u8; words * 4], true);
        let pool = BrickPool {
            gpu: gpu.clone(),
            shape,
            dims,
            bricks,
            map,
            format,
            block,
            _pool: pool,
            pages,
            samples_layout,
            samples,
            requests,
            words,
            cache: BrickCache::new(slots, capacity, nbricks),
            fixed_bytes,
            pool_bytes: capacity as u64 * slot_bytes,
            bounds_cached,
            pass_stamp: 0,
        };
        pool.write_pages();
        Ok((pool, bounds))
    }

    /// Device bytes for a frame of `pixels` (the image buffers reserved for
    /// the largest frame count only as large as this one's).
    pub fn device_bytes(&self, options: &PagedOptions, reserve: Reserve, pixels: u64) -> u64 {
        self.fixed_bytes - options.max_pixels * reserve.per_pixel + pixels * reserve.per_pixel + self.pool_bytes
    }

    fn write_pages(&self) {
        self.gpu.queue.write_texture(
            wgpu::TexelCopyTextureInfo {
                texture: &self.pages,
                mip_level: 0,
                origin: wgpu::Origin3d::ZERO,
                aspect: wgpu::TextureAspect::All,
            },
            bytemuck::cast_slice(&self.cache.pages),
            wgpu::TexelCopyBufferLayout {
                offset: 0,
                bytes_per_row: Some(self.bricks[0] as u32 * 4),
                rows_per_image: Some(self.bricks[1] as u32),
            },
            wgpu::Extent3d {
                width: self.bricks[0] as u32,
                height: self.bricks[1] as u32,
                depth_or_array_layers: self.bricks[2] as u32,
            },
        );
    }

    /// Reads brick `k` (with its halo) from the source into pool slot `slot`.
    fn upload(
        &self,
        source: &dyn BrickSource,
        k: usize,
        slot: usize,
        scratch: &mut Vec<f32>,
    ) -> Result<(), RenderError> {
        let s = self.shape.slot();
        let (b, h) = (self.shape.edge as i64, self.shape.halo as i64);
        let kk = [k % self.bricks[0], (k / self.bricks[0]) % self.bricks[1], k / (self.bricks[0] * self.bricks[1])];
        let lo = kk.map(|c| c as i64 * b - h);
        scratch.resize(s * s * s, 0.0);
        source.read_box(lo, [s, s, s], scratch)?;
        let bytes = self.format.encode_rows(scratch, self.map, s)?;
        let sc = self.cache.slot_coords(slot);
        let per = self.format.per_texel();
        self.gpu.queue.write_texture(
            wgpu::TexelCopyTextureInfo {
                texture: &self._pool,
                mip_level: 0,
                origin: wgpu::Origin3d { x: (sc[0] * s / per) as u32, y: (sc[1] * s) as u32, z: (sc[2] * s) as u32 },
                aspect: wgpu::TextureAspect::All,
            },
            &bytes,
            wgpu::TexelCopyBufferLayout {
                offset: 0,
                bytes_per_row: Some(self.format.row_bytes(s) as u32),
                rows_per_image: Some(s as u32),
            },
            wgpu::Extent3d { width: (s / per) as u32, height: s as u32, depth_or_array_layers: s as u32 },
        );
        Ok(())
    }

    /// One frame's passes: clears the request bits, runs `dispatch` (the
    /// renderer's ray caster over the whole image), and while rays wait,
    /// uploads the bricks they asked for (evicting the least recently
    /// requested) and dispatches again. Returns the frame's statistics
    /// but its time and device bytes, which the renderer fills in.
    pub fn run_passes(
        &mut self,
        source: &dyn BrickSource,
        mut dispatch: impl FnMut() -> Result<(), RenderError>,
    ) -> Result<PagedStats, RenderError> {
        let gpu = self.gpu.clone();
        let (uploads0, evictions0) = (self.cache.uploads, self.cache.evictions);
        let nbricks = self.cache.pages.len();
        let words = self.words;
        let mut passes = 0;
        let mut scratch = Vec::new();
        loop {
            passes += 1;
            if passes > MAX_PASSES {
                return Err(RenderError::FrameIncomplete { passes: MAX_PASSES, slots: self.cache.capacity() });
            }
            gpu.queue.write_buffer(&self.requests, 0, &vec![0u8; words * 4]);
            dispatch()?;
            let bits: Vec<u32> = bytemuck::cast_slice(&gpu.read_buffer(&self.requests)?).to_vec();
            let pending = bits[words - 1];
            if std::env::var_os("BOXFORGE_MEMORY_TRACE").is_some() {
                eprintln!("pass {passes}: {pending} rays wait; RSS {:?}", crate::memory::current_resident_bytes());
            }
            if pending == 0 {
                break;
            }
            let wanted = requested_bricks(&bits[..words - 1], nbricks);
            self.pass_stamp += 1;
            let admitted = self.cache.admit(&wanted, self.pass_stamp);
            if admitted.is_empty() {
                return Err(RenderError::PoolStarved { pending: pending as u64, slots: self.cache.capacity() });
            }
            // Uploads go through staging memory until their copy has run:
            // flush every 2 MiB of it, so the staging never holds a pass's
            // bricks. wgpu stages each row of a texture write padded to
            // COPY_BYTES_PER_ROW_ALIGNMENT (256 bytes): a slot row of 40
            // u8 samples takes 256 bytes there, so count staged bytes.
            let s = self.shape.slot();
            let staged = s * s * self.format.row_bytes(s).next_multiple_of(wgpu::COPY_BYTES_PER_ROW_ALIGNMENT as usize);
            let per_flush = ((2 << 20) / staged).max(1);
            for (i, (k, slot)) in admitted.into_iter().enumerate() {
                self.upload(source, k, slot, &mut scratch)?;
                if (i + 1) % per_flush == 0 {
                    gpu.queue.submit([]);
                    gpu.wait()?;
                }
            }
            self.write_pages();
            // Staging and readback memory of this pass, freed, goes back.
            crate::memory::release_free_heap();
        }
        Ok(PagedStats {
            passes,
            uploads: self.cache.uploads - uploads0,
            evictions: self.cache.evictions - evictions0,
            slots: self.cache.capacity(),
            bricks: nbricks,
            ..PagedStats::default()
        })
    }
}
