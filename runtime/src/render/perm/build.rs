//! The preprocessing: cell bounds, selection, peeling, the index volume and
//! the density and gradient passes on the device; the cache's ray caster.

use super::texture::CacheWords;
use super::{build_index, formula, peel, select_cells, Counts, Index, Memory, Quant, MAX_BYTES, MAX_ROW};
use crate::gpu::binding::{storage_entry, storage_texture_entry, texture_entry};
use crate::gpu::{Gpu, GpuError};
use crate::render::blocks::block_bounds;
use crate::render::dvr::caster::Extra;
use crate::render::dvr::transfer::Tf1d;
use crate::render::dvr::{caster_entries, filter_module_with, shader_source_with, DvrScene};
use crate::volume::DeviceVolume;
use std::time::Instant;
use wgpu::util::DeviceExt;

/// The uniform block of templates/perm.wgsl.j2.
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
struct PermParams {
    dims: [i32; 4],
    quant: [u32; 4],
    scale: [f32; 4],
    tex: [u32; 4],
}

/// The uniform block of templates/perm_build.wgsl.j2.
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
struct BuildParams {
    dims: [u32; 4],
    counts: [u32; 4],
    scale: [f32; 4],
    tex: [u32; 4],
}

/// The runtime template `file` (`perm` or `perm_build`) for filter `name`.
fn template(file: &str, name: &str) -> String {
    crate::render::templates::render(file, minijinja::context! { name => name })
}

/// A PERM cache on the device for one scene, transfer function, step and
/// pre-integration choice, with its ray-casting pipeline.
pub struct PermCache {
    /// The counts the memory formula applies to.
    pub counts: Counts,
    /// Visible cells (before the dilation), x fastest.
    pub visible: Vec<bool>,
    /// Bytes per part: the allocated buffers (gradient magnitudes and signs
    /// share one buffer of words, split 3 : 1).
    pub memory: Memory,
    /// Wall time of the preprocessing: cell bounds, selection, index, the
    /// density and gradient passes (ms).
    pub preprocess_ms: f64,
    /// Largest |gradient component| (the gradient bytes' full scale).
    pub gmax: f32,
    /// Candidate cells dropped by opaque-boundary peeling.
    pub peeled: u64,
    /// The termination opacity the peeling assumed (renders may not exceed it).
    pub peel_termination: Option<f32>,
    /// The index volume and summed-area table, as uploaded.
    pub index: Index,
    pub(super) step: f32,
    pub(super) preintegrate: bool,
    pub(super) table: Vec<[f32; 4]>,
    pub(super) pipeline: wgpu::ComputePipeline,
    pub(super) bgl: wgpu::BindGroupLayout,
    pub(super) params: wgpu::Buffer,
    /// Index volume and summed-area table.
    pub(super) buffers: [wgpu::Buffer; 2],
    /// Densities and gradients.
    pub(super) words: [CacheWords; 2],
}

/// What a cache is built on: the device, the filter, its samples on the
/// device, and their group 0 (layout and bind group) as the ray caster binds it.
pub(crate) struct On<'a> {
    pub gpu: &'a Gpu,
    pub d: &'a boxforge::derive::Derivation,
    pub volume: &'a DeviceVolume,
    pub samples: (&'a wgpu::BindGroupLayout, &'a wgpu::BindGroup),
}

/// Workgroups (x, y) of 64 threads covering `threads`, and threads per row.
fn grid(threads: u64) -> ((u32, u32, u32), u32) {
    let groups = threads.div_ceil(64).max(1);
    let gx = groups.min(65535);
    ((gx as u32, groups.div_ceil(gx) as u32, 1), (gx * 64) as u32)
}

/// Why a PERM cache cannot be built: sizes over what its indices or the
/// device address, named by quantity (the density and gradient resolutions
/// are the positions per cell axis, N and M), or a device error.
#[derive(Debug, thiserror::Error)]
pub enum PermError {
    /// A row of x longer than the 15-bit in-row index addresses.
    #[error("the PERM cache: the volume is {cells} cells along x, over the {MAX_ROW} a 15-bit row index addresses")]
    RowTooLong { cells: usize },
    /// The cache of the candidate cells over [`MAX_BYTES`].
    #[error(
        "the PERM cache at density resolution {} and gradient resolution {}: {} candidate cells need {}, over the limit of {limit} bytes; use a smaller density or gradient resolution",
        counts.quant.density, counts.quant.gradient, counts.candidates, need.describe()
    )]
    TooLarge { counts: Counts, need: Memory, limit: u64 },
    /// The index volume over the device's storage-binding limit.
    #[error(
        "the PERM cache: the index volume of {cells} cells needs {bytes} bytes, over this device's storage-binding limit of {binding} bytes; downsample the volume"
    )]
    IndexVolume { cells: u64, bytes: u64, binding: u64 },
    /// The densities or gradients past what a 3D texture holds.
    #[error(
        "the PERM cache: the {label} need {words} words, more than a 3D texture of {max}^3 texels holds; use a smaller density or gradient resolution"
    )]
    Texture { label: String, words: u64, max: u32 },
    /// The device refused a step of the build.
    #[error(transparent)]
    Gpu(#[from] GpuError),
    /// A frame could not be drawn (an empty or too large target).
    #[error(transparent)]
    Render(#[from] crate::render::RenderError),
    /// The volume could not be stored on the device.
    #[error(transparent)]
    Volume(#[from] crate::volume::VolumeError),
}

impl PermCache {
    /// Preprocesses `scene` for `table` and segments of `step` (dilation
    /// ceil(step) with pre-integration).
    pub fn build(
        scene: &DvrScene,
        table: &Tf1d,
        quant: Quant,
        step: f32,
        preintegrate: bool,
    ) -> Result<PermCache, PermError> {
        Self::build_peeled(scene, table, quant, step, preintegrate, None)
    }

    /// [`PermCache::build`], with opaque-boundary peeling ([`peel`]) for
    /// renders whose termination opacity is at most `peel` when given.
    pub fn build_peeled(
        scene: &DvrScene,
        table: &Tf1d,
        quant: Quant,
        step: f32,
        preintegrate: bool,
        peel_termination: Option<f32>,
    ) -> Result<PermCache, PermError> {
        let on = On { gpu: scene.gpu, d: scene.d, volume: &scene.dv, samples: (&scene.bgl_s, &scene.bg_s) };
        Self::build_on(on, table, quant, step, preintegrate, peel_termination).map(|(cache, _)| cache)
    }

    /// [`PermCache::build_peeled`] on samples already on the device (their
    /// group 0 laid out and bound by the caller, whose ray caster binds the
    /// same group); also returns the preprocessing module, whose emitted
    /// min/max kernel the caller may bound its skipping blocks with.
    pub(crate) fn build_on(
        on: On<'_>,
        table: &Tf1d,
        quant: Quant,
        step: f32,
        preintegrate: bool,
        peel_termination: Option<f32>,
    ) -> Result<(PermCache, wgpu::ShaderModule), PermError> {
        let start = Instant::now();
        let (gpu, d, volume) = (on.gpu, on.d, on.volume);
        let (samples_layout, samples) = on.samples;
        let dev = &gpu.device;
        let name = &d.filter.name;
        let dims = volume.dims;
        if dims[0] > MAX_ROW {
            return Err(PermError::RowTooLong { cells: dims[0] });
        }
        let build_src = format!(
            "{}\n{}",
            filter_module_with(d, &volume.emit_options(crate::render::dvr::DVR_COMMAND))?,
            template("perm_build", name)
        );
        let build = gpu.compile(&format!("{name}.perm_build.wgsl"), &build_src)?;
        let bounds = block_bounds(gpu, &build, name, volume, dims, 1)?;
        let radius = if preintegrate { step.ceil() as i32 } else { 0 };
        let (visible, mut candidate) = select_cells(&bounds, dims, table, radius);
        let peeled = peel_termination.map_or(0, |t| peel(&bounds, dims, table, step, t, &mut candidate));
        let index = build_index(&candidate, &bounds, dims, table);
        let counts = Counts {
            cells: (dims[0] * dims[1] * dims[2]) as u64,
            rows: (dims[1] * dims[2]) as u64,
            candidates: index.cells.len() as u64,
            quant,
        };
        let need = formula(&counts);
        let limit = MAX_BYTES;
        if need.total() > limit {
            return Err(PermError::TooLarge { counts, need, limit });
        }
        let binding = gpu.limits().max_storage_buffer_binding_size.min(gpu.limits().max_buffer_size);
        if need.index_volume > binding {
            return Err(PermError::IndexVolume { cells: counts.cells, bytes: need.index_volume, binding });
        }
        let span = table.hi - table.lo;
        let (n3, m3) = (quant.density.pow(3) as u64, quant.gradient.pow(3) as u64);
        let (nd, ng) = (counts.candidates * n3, counts.candidates * m3);
        let iv = gpu.storage_buffer("perm index volume", bytemuck::cast_slice(&index.words), false);
        let sat = gpu.storage_buffer("perm summed-area table", bytemuck::cast_slice(&index.sat), false);
        let cells_buf = gpu.storage_buffer("perm cells", bytemuck::cast_slice(&index.cells), false);
        let db = CacheWords::new(gpu, "PERM densities", nd.div_ceil(2))?;
        let gb = CacheWords::new(gpu, "PERM gradients", ng)?;
        let gmax_buf = gpu.storage_buffer("perm gmax", &[0u8; 4], true);
        let bgl_b = dev.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("perm build"),
            entries: &[gpu.params_entry(0), storage_entry(1, true), storage_texture_entry(2), storage_entry(3, false)],
        });
        let pass = |entry: &str, out: &CacheWords, n: u32, threads: u64, positions: u64, scale: [f32; 4]| {
            let (groups, row) = grid(threads);
            let p = BuildParams {
                dims: [dims[0] as u32, dims[1] as u32, dims[2] as u32, counts.candidates as u32],
                counts: [n, n.pow(3), positions as u32, row],
                scale,
                tex: [out.extent[0], out.extent[1], 0, 0],
            };
            let pbuf = gpu.uniform_buffer("perm build params", bytemuck::bytes_of(&p));
            let bg = dev.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("perm build"),
                layout: &bgl_b,
                entries: &[
                    wgpu::BindGroupEntry { binding: 0, resource: pbuf.as_entire_binding() },
                    wgpu::BindGroupEntry { binding: 1, resource: cells_buf.as_entire_binding() },
                    wgpu::BindGroupEntry { binding: 2, resource: wgpu::BindingResource::TextureView(&out.view) },
                    wgpu::BindGroupEntry { binding: 3, resource: gmax_buf.as_entire_binding() },
                ],
            });
            let pipe = gpu.pipeline(entry, &build, &[samples_layout, &bgl_b], &format!("{name}_{entry}"))?;
            if threads > 0 {
                gpu.dispatch(entry, &pipe, &[samples, &bg], groups)?;
            }
            gpu.wait()
        };
        let units = 65535.0 / span;
        pass("perm_density_main", &db, quant.density, nd.div_ceil(2), nd, [table.lo, units, 0.0, 0.0])?;
        let dummy = CacheWords::new(gpu, "PERM unused", 1)?;
        pass("perm_gmax_main", &dummy, quant.gradient, ng, ng, [0.0; 4])?;
        let gmax = f32::from_bits(u32::from_le_bytes(gpu.read_buffer(&gmax_buf)?[..4].try_into().unwrap()));
        let gscale = if gmax > 0.0 { 255.0 / gmax } else { 0.0 };
        pass("perm_gradient_main", &gb, quant.gradient, ng, ng, [0.0, 0.0, gscale, 0.0])?;
        let preprocess_ms = start.elapsed().as_secs_f64() * 1e3;

        let render_src = format!(
            "{}\n{}",
            shader_source_with(d, &volume.emit_options(crate::render::dvr::DVR_COMMAND), true)?,
            template("perm", name)
        );
        let shader = gpu.compile(&format!("{name}.dvr_perm.wgsl"), &render_src)?;
        let mut entries = caster_entries(gpu);
        entries.extend([
            gpu.params_entry(5),
            storage_entry(6, true),
            storage_entry(7, true),
            texture_entry(8),
            texture_entry(9),
        ]);
        let bgl = dev
            .create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor { label: Some("dvr perm"), entries: &entries });
        let pipeline = gpu.pipeline("dvr perm", &shader, &[samples_layout, &bgl], &format!("{name}_dvr_main"))?;
        let params = PermParams {
            dims: [dims[0] as i32, dims[1] as i32, dims[2] as i32, 0],
            quant: [quant.density, quant.gradient, n3 as u32, m3 as u32],
            scale: [table.lo, span / 65535.0, span / 32767.0, gmax / 255.0],
            tex: [db.extent[0], db.extent[1], gb.extent[0], gb.extent[1]],
        };
        let params = dev.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("perm params"),
            contents: bytemuck::bytes_of(&params),
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::STORAGE,
        });
        let g = gb.bytes();
        let memory = Memory {
            index_volume: iv.size(),
            summed_area: sat.size(),
            density: db.bytes(),
            gradient: g / 4 * 3,
            sign: g / 4,
        };
        let cache = PermCache {
            counts,
            visible,
            memory,
            preprocess_ms,
            gmax,
            peeled,
            peel_termination,
            index,
            step,
            preintegrate,
            table: table.entries.clone(),
            pipeline,
            bgl,
            params,
            buffers: [iv, sat],
            words: [db, gb],
        };
        Ok((cache, build))
    }

    /// The cache's group-1 resources after the DVR template's five: its
    /// parameters, the index volume, the summed-area table, the densities
    /// and the gradients (bindings 5 to 9 of templates/perm.wgsl.j2).
    pub(crate) fn extras(&self) -> Vec<(u32, Extra)> {
        let [iv, sat] = &self.buffers;
        vec![
            (5, Extra::Buffer(self.params.clone())),
            (6, Extra::Buffer(iv.clone())),
            (7, Extra::Buffer(sat.clone())),
            (8, Extra::Texture(self.words[0].view.clone())),
            (9, Extra::Texture(self.words[1].view.clone())),
        ]
    }

    /// The densities as stored (16-bit fixed point, decoded to values).
    pub fn densities(&self, gpu: &Gpu, table: &Tf1d) -> Result<Vec<f32>, GpuError> {
        let words = self.words[0].read(gpu)?;
        let unit = (table.hi - table.lo) / 65535.0;
        let n = self.counts.candidates as usize * self.counts.quant.density.pow(3) as usize;
        Ok((0..n).map(|m| table.lo + unit * ((words[m >> 1] >> ((m & 1) << 4)) & 0xffff) as f32).collect())
    }
}
