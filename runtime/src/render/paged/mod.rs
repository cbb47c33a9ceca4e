//! Out of core: isosurfaces of volumes larger than the device's memory
//! budget (and than one texture). The samples live in bricks of the
//! bricked layout ([`boxforge::emit::bricks`]); a pool of as many brick
//! slots as the budget holds is filled on demand. A frame renders in
//! passes: the ray caster walks each ray as the in-core fixed-step walk
//! does until it needs a brick the pool lacks, records the brick and where
//! to resume, and stops; the host uploads the requested bricks (evicting
//! the least recently requested) and dispatches again until every ray is
//! done. The image equals the in-core one: the same evaluations at the same
//! points, and where a block is known empty its bounds' midpoint stands in
//! for the value (same sign), so bricks holding only empty blocks are never
//! uploaded.
//!
//! The block bounds are computed brick row by brick row before the first
//! frame ([`bounds`]), so nothing needs the whole volume on the device or
//! in host memory when the source is a mapped file.

pub mod bounds;
pub mod cache;

use crate::gpu::binding::{entries_for, layout_entries_from};
use crate::gpu::{Gpu, GpuError};
use crate::render::blocks::{self, SkipMap};
use crate::render::iso::{ray_params_for, Frame, RayParams, RenderOptions};
use crate::render::RenderError;
use crate::volume::{slot_grid, BrickShape, BrickSource, SampleFormat};
use boxforge::derive::Derivation;
use boxforge::emit::{emit, EmitOptions, Layout};
use cache::{requested_bricks, BrickCache};

/// What an out-of-core isosurface needs besides the camera.
#[derive(Clone, Debug)]
pub struct PagedOptions {
    /// The iso-value.
    pub iso: f32,
    /// Ray step in cells.
    pub step: f32,
    /// Edge of the min/max blocks in unit cubes (divides the brick edge).
    pub block: i32,
    /// Brick edge in lattice texels (a multiple of the block edge and of the
    /// lattice's period); the halo is the filter's.
    pub brick: usize,
    /// Stored sample format.
    pub format: SampleFormat,
    /// Device memory for everything this renderer allocates, in bytes.
    pub budget: u64,
    /// The largest image (pixels) the budget reserves room for.
    pub max_pixels: u64,
    /// Cap on the pool texture's edge (None: the adapter's limit); tests
    /// force small pools with it.
    pub max_pool_edge: Option<usize>,
    /// A folder where the block bounds of a source with an
    /// [`identity`](BrickSource::identity) are kept (`bounds-<key>.bin`), so a
    /// second render of the same file, filter and storage skips the pass
    /// over the whole volume (minutes at 1024^3); None: always computed.
    pub bounds_cache: Option<std::path::PathBuf>,
}

impl Default for PagedOptions {
    fn default() -> Self {
        PagedOptions {
            iso: 0.5,
            step: 0.25,
            block: 4,
            brick: BrickShape::DEFAULT_EDGE,
            format: SampleFormat::F32,
            budget: 1 << 30,
            max_pixels: 512 * 512,
            bounds_cache: None,
            max_pool_edge: None,
        }
    }
}

/// What rendering one frame out of core took.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize)]
pub struct PagedStats {
    /// Dispatches of the ray caster (1: everything was resident).
    pub passes: usize,
    /// Bricks uploaded during the frame.
    pub uploads: usize,
    /// Bricks evicted during the frame.
    pub evictions: usize,
    /// Slots in the pool.
    pub slots: usize,
    /// Bricks of the volume.
    pub bricks: usize,
    /// Bricks with a non-empty block for this iso-value (the most a frame can need).
    pub occupied_bricks: usize,
    /// Device bytes this renderer allocated (pool, page table, bounds, image buffers).
    pub device_bytes: u64,
    /// Milliseconds of the frame (all passes, uploads included).
    pub ms: f64,
}

/// An isosurface of a [`BrickSource`] rendered out of core (see the module documentation).
pub struct PagedIsoRenderer {
    gpu: Gpu,
    name: String,
    options: PagedOptions,
    shape: BrickShape,
    radius: usize,
    dims: [usize; 3],
    bricks: [usize; 3],
    map: boxforge::emit::SampleMap,
    pipeline: wgpu::ComputePipeline,
    bindings: Vec<boxforge::validate::Binding>,
    caster_layout: wgpu::BindGroupLayout,
    samples: wgpu::BindGroup,
    pool: wgpu::Texture,
    pages: wgpu::Texture,
    blocks: wgpu::Buffer,
    cache: BrickCache,
    fixed_bytes: u64,
    pool_bytes: u64,
    occupied_bricks: usize,
    empty_blocks: f64,
    /// Whether the block bounds came from [`PagedOptions::bounds_cache`].
    bounds_cached: bool,
    /// Passes rendered so far, over all frames (the cache's clock).
    pass_stamp: u64,
}

/// Bytes per pixel of the frame buffers: image, depth, resume state.
const PIXEL_BYTES: u64 = 4 + 4 + 16;

/// The most passes one frame may take before the pool is declared too small.
pub const MAX_PASSES: usize = 4096;

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
        let mut options = options;
        let fail = |m: String| RenderError::Gpu(GpuError::Runtime(m));
        let name = d.filter.name.clone();
        let dims = source.dims();
        let period = bounds::lattice_period(source.lattice());
        // The block edge grows (doubling, up to the brick) until the bounds
        // with the distance map (12 bytes a block) fit one storage binding
        // and an eighth of the budget: a large volume gets coarser blocks.
        let binding_limit = gpu.limits().max_storage_buffer_binding_size;
        let mut block = options.block.max(1) as usize;
        let bounds_bytes = |b: usize| dims.iter().map(|n| n.div_ceil(b) as u64).product::<u64>() * 12;
        while 2 * block <= options.brick
            && options.brick.is_multiple_of(2 * block)
            && bounds_bytes(block) > binding_limit.min(options.budget / 8)
        {
            block *= 2;
        }
        options.block = block as i32;
        if options.brick == 0 || !options.brick.is_multiple_of(block) || !options.brick.is_multiple_of(period) {
            return Err(fail(format!(
                "brick edge {} must be a multiple of the block edge {block} and of the lattice's period {period}; e.g. --brick 32",
                options.brick
            )));
        }
        let shape = BrickShape { edge: options.brick, halo: boxforge::emit::bricks::brick_halo(d) };
        let slot = shape.slot();
        let bricks = dims.map(|n| n.div_ceil(shape.edge));
        let nbricks = bricks.iter().product::<usize>();
        let nblocks: usize = dims.iter().map(|n| n.div_ceil(block)).product();
        let format = options.format;
        let slot_bytes = (slot * slot * slot * format.bytes()) as u64;
        // Everything but the pool: page table, bounds with the distance map,
        // request bits, the largest image's buffers.
        let fixed_bytes = nbricks as u64 * 4
            + nblocks as u64 * 12
            + (nbricks as u64).div_ceil(32) * 4
            + 4
            + options.max_pixels * PIXEL_BYTES
            + 1024;
        let need = fixed_bytes + 8 * slot_bytes;
        if options.budget < need {
            return Err(fail(format!(
                "a device budget of {} is too small: the page table, block bounds and image buffers take {} and the pool needs at least 8 brick slots of {} ({slot}^3 texels of {}); give at least {}",
                human(options.budget),
                human(fixed_bytes),
                human(slot_bytes),
                format.name(),
                human(need)
            )));
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
            return Err(fail(format!(
                "a pool texture of at most {max_edge} texels per edge holds {capacity} slots of {slot}^3; use a smaller --brick"
            )));
        }
        let mem = |what: &str| {
            if std::env::var_os("BOXFORGE_MEMORY_TRACE").is_some() {
                eprintln!(
                    "{what}: RSS {:?} HWM {:?}",
                    crate::memory::current_resident_bytes(),
                    crate::memory::peak_resident_bytes()
                );
            }
        };
        mem("start");
        // Only the normalized formats need the range (a pass over the source).
        let map = match format {
            SampleFormat::U8 | SampleFormat::U16 => {
                let (lo, hi) = source.sample_range().map_err(|e| fail(e.to_string()))?;
                format.map_for(lo, hi)
            }
            SampleFormat::F32 | SampleFormat::F16 => boxforge::emit::SampleMap::IDENTITY,
        };
        mem("range");
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

        mem("bounds");
        // The block tables are only needed until their device copy exists:
        // drop them here and hand their memory back before the pool fills.
        let (blocks_buf, empty_blocks, occupied_bricks) = {
            let iso = options.iso;
            let empty: Vec<u32> = bounds.iter().map(|b| (iso < b[0] || iso > b[1]) as u32).collect();
            let empty_blocks = empty.iter().filter(|&&e| e != 0).count() as f64 / empty.len().max(1) as f64;
            let grid = blocks::blocks_per_axis(dims, options.block);
            let occupied_bricks = occupied(&empty, grid, bricks, shape.edge / block);
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

        mem("skip map");
        let module = EmitOptions {
            layout: Layout::Bricked,
            samples: map,
            command: "boxforge_runtime::render::paged::PagedIsoRenderer".into(),
            kernels: false,
            ..Default::default()
        };
        let m = emit(d, &module).map_err(|e| fail(e.to_string()))?;
        let source_text = format!("{}\n{}", m.source, crate::render::iso::template::paged_template(&name));
        let shader = gpu.compile(&format!("{name}.paged.wgsl"), &source_text)?;
        let bindings = boxforge::validate::bindings_of_wgsl(&source_text)
            .map_err(|message| GpuError::Shader { label: format!("{name}.paged.wgsl"), message })?;
        let dev = &gpu.device;
        let pool_size = slots.map(|s| (s * slot) as u32);
        let pool = dev.create_texture(&wgpu::TextureDescriptor {
            label: Some("brick pool"),
            size: wgpu::Extent3d { width: pool_size[0], height: pool_size[1], depth_or_array_layers: pool_size[2] },
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D3,
            format: format.texture_format(),
            usage: wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST,
            view_formats: &[],
        });
        let pages = dev.create_texture(&wgpu::TextureDescriptor {
            label: Some("page table"),
            size: wgpu::Extent3d {
                width: bricks[0] as u32,
                height: bricks[1] as u32,
                depth_or_array_layers: bricks[2] as u32,
            },
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D3,
            format: wgpu::TextureFormat::R32Uint,
            usage: wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST,
            view_formats: &[],
        });
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
                crate::gpu::binding::texture_3d_entry(0, wgpu::ShaderStages::COMPUTE, false),
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
        let caster_layout = dev.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("paged raycast"),
            entries: &layout_entries_from(&bindings, 1)?,
        });
        let pipeline = gpu.pipeline(
            "paged raycast",
            &shader,
            &[&samples_layout, &caster_layout],
            &format!("{name}_raycast_main"),
        )?;
        let cache = BrickCache::new(slots, capacity, nbricks);
        let pool_bytes = slots.iter().product::<usize>() as u64 * slot_bytes;
        let renderer = PagedIsoRenderer {
            gpu: gpu.clone(),
            name,
            options,
            shape,
            radius: crate::verify::support_radius(d),
            dims,
            bricks,
            map,
            pipeline,
            bindings,
            caster_layout,
            samples,
            pool,
            pages,
            blocks: blocks_buf,
            cache,
            fixed_bytes,
            pool_bytes,
            occupied_bricks,
            empty_blocks,
            bounds_cached,
            pass_stamp: 0,
        };
        renderer.write_pages();
        mem("pool");
        Ok(renderer)
    }

    /// The filter this renderer evaluates.
    /// Whether the block bounds were read from the bounds cache (not
    /// computed by a pass over the source).
    pub fn bounds_cached(&self) -> bool {
        self.bounds_cached
    }

    pub fn filter_name(&self) -> &str {
        &self.name
    }

    /// The sample map the pool's texels are read with.
    pub fn sample_map(&self) -> boxforge::emit::SampleMap {
        self.map
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
        let fail = |m: String| RenderError::Gpu(GpuError::Runtime(m));
        source.read_box(lo, [s, s, s], scratch).map_err(|e| fail(e.to_string()))?;
        let bytes = self.options.format.encode(scratch, self.map).map_err(|e| fail(e.to_string()))?;
        let sc = self.cache.slot_coords(slot);
        let fb = self.options.format.bytes() as u32;
        self.gpu.queue.write_texture(
            wgpu::TexelCopyTextureInfo {
                texture: &self.pool,
                mip_level: 0,
                origin: wgpu::Origin3d { x: (sc[0] * s) as u32, y: (sc[1] * s) as u32, z: (sc[2] * s) as u32 },
                aspect: wgpu::TextureAspect::All,
            },
            &bytes,
            wgpu::TexelCopyBufferLayout {
                offset: 0,
                bytes_per_row: Some(s as u32 * fb),
                rows_per_image: Some(s as u32),
            },
            wgpu::Extent3d { width: s as u32, height: s as u32, depth_or_array_layers: s as u32 },
        );
        Ok(())
    }

    /// One frame: passes until every ray is done. `o` gives the camera and
    /// image size (its iso, step and block must be this renderer's).
    pub fn render(&mut self, source: &dyn BrickSource, o: &RenderOptions) -> Result<(Frame, PagedStats), RenderError> {
        let fail = |m: String| RenderError::Gpu(GpuError::Runtime(m));
        let pixels = o.width as u64 * o.height as u64;
        if pixels == 0 {
            return Err(RenderError::EmptyTarget);
        }
        if pixels > self.options.max_pixels {
            return Err(fail(format!(
                "a {}x{} frame is larger than the {} pixels this renderer's budget reserved (PagedOptions::max_pixels)",
                o.width, o.height, self.options.max_pixels
            )));
        }
        let start = std::time::Instant::now();
        let (uploads0, evictions0) = (self.cache.uploads, self.cache.evictions);
        let gpu = &self.gpu;
        let o = RenderOptions {
            iso: self.options.iso,
            step: self.options.step,
            block: self.options.block,
            skip: true,
            skip_map: SkipMap::Distance,
            ..o.clone()
        };
        let params: RayParams = ray_params_for(self.radius, self.dims, &o);
        let params_buf = gpu.uniform_buffer("paged params", bytemuck::bytes_of(&params));
        let n = pixels as usize;
        let image = gpu.storage_buffer("paged image", &vec![0u8; n * 4], true);
        let depth = gpu.storage_buffer("paged depth", &vec![0u8; n * 4], true);
        let resume = gpu.storage_buffer("paged resume", &vec![0u8; n * 16], true);
        let nbricks = self.cache.pages.len();
        let words = nbricks.div_ceil(32) + 1;
        let requests = gpu.storage_buffer("paged requests", &vec![0u8; words * 4], true);
        let resources = [(0, &params_buf), (1, &image), (2, &self.blocks), (3, &depth), (8, &resume), (9, &requests)];
        let entries = entries_for(&self.bindings, 1, &resources);
        let caster = gpu.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("paged raycast"),
            layout: &self.caster_layout,
            entries: &entries,
        });
        let groups = (o.width.div_ceil(8), o.height.div_ceil(8), 1);
        let mut passes = 0;
        let mut scratch = Vec::new();
        loop {
            passes += 1;
            if passes > MAX_PASSES {
                return Err(fail(format!(
                    "the frame did not complete in {MAX_PASSES} passes: the pool of {} slots is too small for the bricks its rays need at once; raise the budget",
                    self.cache.capacity()
                )));
            }
            gpu.queue.write_buffer(&requests, 0, &vec![0u8; words * 4]);
            gpu.dispatch("paged raycast", &self.pipeline, &[&self.samples, &caster], groups)?;
            let bits: Vec<u32> = bytemuck::cast_slice(&gpu.read_buffer(&requests)?).to_vec();
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
                return Err(fail(format!(
                    "{pending} rays wait for bricks but none fits the pool of {} slots: raise the budget",
                    self.cache.capacity()
                )));
            }
            // Uploads go through staging memory until their copy has run:
            // flush every few MiB, so the staging never holds a pass's bricks.
            let per_flush = ((4 << 20) / (self.shape.slot().pow(3) * self.options.format.bytes())).max(1);
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
        let words: Vec<u32> = bytemuck::cast_slice(&gpu.read_buffer(&image)?).to_vec();
        let rgba = bytemuck::cast_slice(&words).to_vec();
        let ms = start.elapsed().as_secs_f64() * 1e3;
        let frame = Frame {
            width: o.width,
            height: o.height,
            rgba,
            ms_per_frame: ms,
            empty_blocks: self.empty_blocks,
            skip_map: None,
        };
        let stats = PagedStats {
            passes,
            uploads: self.cache.uploads - uploads0,
            evictions: self.cache.evictions - evictions0,
            slots: self.cache.capacity(),
            bricks: nbricks,
            occupied_bricks: self.occupied_bricks,
            device_bytes: self.fixed_bytes - self.options.max_pixels * PIXEL_BYTES
                + pixels * PIXEL_BYTES
                + self.pool_bytes,
            ms,
        };
        Ok((frame, stats))
    }
}

/// Bricks holding at least one block whose bounds contain the iso-value
/// (`per` blocks per brick edge).
fn occupied(empty: &[u32], grid: [i32; 3], bricks: [usize; 3], per: usize) -> usize {
    let mut occ = vec![false; bricks.iter().product()];
    let g = grid.map(|n| n as usize);
    for z in 0..g[2] {
        for y in 0..g[1] {
            for x in 0..g[0] {
                if empty[x + g[0] * (y + g[1] * z)] == 0 {
                    occ[x / per + bricks[0] * (y / per + bricks[1] * (z / per))] = true;
                }
            }
        }
    }
    occ.iter().filter(|&&o| o).count()
}

/// Bytes as KiB, MiB or GiB.
pub fn human(bytes: u64) -> String {
    const K: f64 = 1024.0;
    let b = bytes as f64;
    if b >= K * K * K {
        format!("{:.2} GiB", b / (K * K * K))
    } else if b >= K * K {
        format!("{:.1} MiB", b / (K * K))
    } else if b >= K {
        format!("{:.1} KiB", b / K)
    } else {
        format!("{bytes} B")
    }
}
