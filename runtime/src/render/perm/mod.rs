//! PERM (`render --mode dvr --cache perm --qc N [--qc-grad M]`): Lim and
//! Shin's precomputed density and gradient map. Before rendering, the
//! density and the analytic gradient (the emitted `<f>_eval_grad`) are
//! computed on the device at N^3 (density) and M^3 (gradient, the paper's
//! unequal quantization) positions in every candidate cell; the ray caster
//! of [`crate::render::dvr`] then reads the nearest position instead of evaluating
//! the spline (templates/perm.wgsl.j2 for the lookup and the formats,
//! templates/perm_build.wgsl.j2 for the preprocessing).
//!
//! Cells are the unit cubes of the empty-space-skipping grid. A cell is
//! *visible* when the transfer function is not transparent over its
//! [min, max] (the emitted min/max kernel with a block edge of 1, judged by
//! [`Tf1d::transparent`] as the skipping is). With pre-integration a segment
//! integrates the ramp between its two end values, so a segment from a
//! visible cell into a transparent neighbour needs that neighbour's true
//! value: the candidates are the visible cells dilated by ceil(step) cells
//! (Chebyshev), which holds every end of every segment touching a visible
//! cell; without pre-integration only the back value matters and the
//! candidates are the visible cells. Any other cell keeps one substitute
//! value in its index-volume entry (the middle of its [min, max], which the
//! transfer function maps to zero), so segments between non-candidates
//! integrate to zero, as they do exactly.
//!
//! The index volume has one 16-bit entry per cell and a summed-area table
//! (prefix counts) per row of x rather than per z-slice as in the paper: a
//! row has fewer than 32768 cells, so the entry's 15 bits always suffice.
//! Memory follows the paper's equations 3 and 6 with b_iv = 2, b_db = 2,
//! b_gb = 1, b_sb = 1, plus the table's 4 bytes per row ([`formula`]);
//! [`PermCache::memory`] reports the allocated buffers' sizes.
//!
//! Opaque-boundary peeling (the paper's section 5, `--peel`) drops the
//! candidate cells that no ray from outside the volume reaches before early
//! ray termination: cells enclosed by enough opaque or translucent matter
//! (the paper's properties 1 and 2) that every ray accumulates the
//! termination opacity first. [`peel`] proves it per cell with a lower bound
//! on the optical depth, so the image is the unpeeled cache's, exactly, for
//! every view from outside the volume (the renderers' orbit cameras); the
//! cache stays view-independent.

use crate::gpu::binding::{storage_entry, storage_texture_entry, texture_entry, uniform_entry};
use crate::gpu::{Gpu, GpuError};
use crate::render::blocks::block_bounds;
use crate::render::dvr::transfer::{Preint, Tf1d, TransferFunction};
use crate::render::dvr::{caster_entries, filter_module, shader_source_with, Caster, DvrOptions, DvrScene};
use crate::render::iso::Frame;
use std::time::Instant;
use wgpu::util::DeviceExt;

/// Bytes of one index-volume entry (b_iv).
pub const B_IV: u64 = 2;
/// Bytes of one summed-area-table entry (per row of x).
pub const B_SAT: u64 = 4;
/// Bytes of one density (b_db): 16-bit fixed point over the TF range.
pub const B_DB: u64 = 2;
/// Bytes of one gradient component's magnitude (b_gb).
pub const B_GB: u64 = 1;
/// Bytes of one gradient's sign field (b_sb).
pub const B_SB: u64 = 1;
/// The largest cache (bytes) `--qc` may ask for: the size one storage
/// buffer may safely have and the range of the shader's u32 indices.
pub const MAX_BYTES: u64 = 1 << 31;
/// Cells per row the 15-bit in-row index can address.
pub const MAX_ROW: usize = 1 << 15;
/// The paper's density quantization (`--qc` default).
pub const DEFAULT_QC: u32 = 5;

/// Quantized positions per cell axis.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Quant {
    /// N: density positions per axis (N^3 per cell).
    pub density: u32,
    /// M: gradient positions per axis (M^3 per cell).
    pub gradient: u32,
}

/// The sizes the memory formula is applied to.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Counts {
    /// S: cells of the volume.
    pub cells: u64,
    /// Rows of x (entries of the summed-area table).
    pub rows: u64,
    /// N_cc: candidate cells.
    pub candidates: u64,
    /// N and M.
    pub quant: Quant,
}

/// Bytes per part of the cache.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
pub struct Memory {
    /// Index volume (IV).
    pub index_volume: u64,
    /// Summed-area table.
    pub summed_area: u64,
    /// Density buffer (DB).
    pub density: u64,
    /// Gradient magnitudes (GB).
    pub gradient: u64,
    /// Gradient signs (SB).
    pub sign: u64,
}

impl Memory {
    /// All parts.
    pub fn total(&self) -> u64 {
        self.index_volume + self.summed_area + self.density + self.gradient + self.sign
    }

    /// One line, bytes per part.
    pub fn describe(&self) -> String {
        format!(
            "{} bytes (index volume {}, summed-area table {}, densities {}, gradients {}, signs {})",
            self.total(),
            self.index_volume,
            self.summed_area,
            self.density,
            self.gradient,
            self.sign
        )
    }
}

/// The paper's equation 6 (equation 3 when N = M) with our byte sizes, plus
/// the summed-area table: S b_iv + rows b_sat + N_cc N^3 b_db +
/// N_cc M^3 (3 b_gb + b_sb).
pub fn formula(c: &Counts) -> Memory {
    let (n3, m3) = (u64::from(c.quant.density).pow(3), u64::from(c.quant.gradient).pow(3));
    Memory {
        index_volume: c.cells * B_IV,
        summed_area: c.rows * B_SAT,
        density: c.candidates * n3 * B_DB,
        gradient: c.candidates * m3 * 3 * B_GB,
        sign: c.candidates * m3 * B_SB,
    }
}

/// The `--cache`, `--qc` and `--qc-grad` options, checked before any GPU
/// work: `None` for `--cache none`. The memory check here is the cache of
/// a single candidate cell (a lower bound); [`PermCache::build`] checks the
/// exact size once the candidates are known.
pub fn check_request(cache: &str, mode: &str, qc: Option<u32>, qc_grad: Option<u32>) -> Result<Option<Quant>, String> {
    match cache {
        "none" => {
            return match (qc, qc_grad) {
                (None, None) => Ok(None),
                _ => Err("--qc and --qc-grad size the PERM cache: add --cache perm (with --mode dvr)".into()),
            }
        }
        "perm" => {}
        other => return Err(format!("--cache {other}: unknown cache; use --cache none or --cache perm")),
    }
    if mode != "dvr" {
        return Err(format!(
            "--cache perm precomputes the values direct volume rendering samples; --mode {mode} has no such cache: add --mode dvr --tf ..., or drop --cache perm"
        ));
    }
    let n = qc.unwrap_or(DEFAULT_QC);
    let quant = Quant { density: n, gradient: qc_grad.unwrap_or(n) };
    for (flag, v) in [("--qc", quant.density), ("--qc-grad", quant.gradient)] {
        if v == 0 {
            return Err(format!(
                "{flag} 0: a cell needs at least one quantized position per axis; use 1 or more (the paper uses 5, and 3 for gradients)"
            ));
        }
    }
    let one = formula(&Counts { cells: 0, rows: 0, candidates: 1, quant }).total();
    if one > MAX_BYTES {
        let largest = (1..)
            .take_while(|&k| {
                formula(&Counts { cells: 0, rows: 0, candidates: 1, quant: Quant { density: k, gradient: k } }).total()
                    <= MAX_BYTES
            })
            .last()
            .unwrap_or(1);
        return Err(format!(
            "--qc {} --qc-grad {}: one candidate cell alone needs {one} bytes of PERM cache ({}^3 x {B_DB} + {}^3 x {}), over the limit of {MAX_BYTES} bytes; use --qc {largest} or less",
            quant.density,
            quant.gradient,
            quant.density,
            quant.gradient,
            3 * B_GB + B_SB
        ));
    }
    Ok(Some(quant))
}

/// Which cells are cached: visible cells (the transfer function is not
/// transparent over the cell's [min, max]) dilated by `radius` cells.
/// Returns (visible, candidate) flags, x fastest.
pub fn select_cells(bounds: &[[f32; 2]], dims: [usize; 3], table: &Tf1d, radius: i32) -> (Vec<bool>, Vec<bool>) {
    let empty: Vec<u32> = crate::render::dvr::empty_flags(bounds, table);
    let visible = empty.iter().map(|&e| e == 0).collect();
    // A cell is far from every visible cell when it and all cells within
    // the radius are transparent: the skipping's min filter.
    let far = crate::render::dvr::skip_flags(&empty, dims.map(|n| n as i32), radius);
    (visible, far.iter().map(|&f| f == 0).collect())
}

/// The index volume and summed-area table of templates/perm.wgsl.j2.
#[derive(Clone, Debug, PartialEq)]
pub struct Index {
    /// 16-bit entries, two per word (cell 2i in the low half of word i).
    pub words: Vec<u32>,
    /// Per row of x: the candidates of all earlier rows.
    pub sat: Vec<u32>,
    /// Candidate cells in slot order (linear cell index).
    pub cells: Vec<u32>,
}

/// Opaque-boundary peeling: clears `candidate` for every cell that no ray
/// entering the volume from outside samples before its opacity reaches
/// `termination`; returns how many it cleared.
///
/// The bound: with `tau(c)` the smallest extinction (per cell length) the
/// table gives over the values of cell c and of the cells within
/// ceil(step) of it (every segment with an end in c ramps between values
/// in that hull, pre-integrated or not), let R_t be the cells with
/// tau >= t. A cell whose Chebyshev neighbourhood of radius d - 1 lies in
/// R_t (the volume's outside counts as outside R_t) is reached only along a
/// path of length >= d - 1 inside R_t, whose optical depth is >= t (d - 1 -
/// 2 step) once the two partial segments at its ends are discounted; the ray
/// caster tests the opacity before each segment, so a segment ending in the
/// cell is never taken when t (d - 1 - 3 step) >= -ln(1 - termination).
/// Each t of a geometric ladder below the largest extinction is tried; a
/// cell is peeled when one proves it.
pub fn peel(
    bounds: &[[f32; 2]],
    dims: [usize; 3],
    table: &Tf1d,
    step: f32,
    termination: f32,
    candidate: &mut [bool],
) -> u64 {
    if !(0.0..1.0).contains(&termination) {
        return 0;
    }
    let reach = (step.ceil() as usize).max(1);
    let hull = crate::render::dvr::widen_bounds(bounds, dims, 1, reach);
    let n = table.entries.len();
    let tau: Vec<f64> = hull
        .iter()
        .map(|b| {
            if b[0].is_nan() || b[1].is_nan() || b[0] > b[1] {
                return 0.0;
            }
            let lo = table.coord(b[0] as f64).floor() as usize;
            let hi = (table.coord(b[1] as f64).ceil() as usize).min(n - 1);
            table.entries[lo.min(hi)..=hi].iter().map(|e| e[3] as f64).fold(f64::INFINITY, f64::min)
        })
        .collect();
    let depth_needed = -(1.0 - termination as f64).ln();
    let tmax = tau.iter().cloned().fold(0.0f64, f64::max);
    let cells = dims[0] * dims[1] * dims[2];
    let mut peeled = vec![false; cells];
    let largest = *dims.iter().min().unwrap_or(&0);
    for k in 0..12 {
        let t = tmax / f64::from(1u32 << k);
        if t <= 0.0 {
            break;
        }
        // Cells whose neighbourhood of radius d - 1 lies in R_t.
        let d = (1.0 + 3.0 * step as f64 + depth_needed / t).ceil() as usize;
        if 2 * d > largest + 1 {
            continue; // no cell of this volume is that deep
        }
        let inside: Vec<u32> = tau.iter().map(|&x| u32::from(x >= t)).collect();
        let deep = crate::render::dvr::skip_flags(&inside, dims.map(|v| v as i32), (d - 1) as i32);
        // skip_flags treats the volume's edge as inside; cells within d - 1
        // of the edge are reached from outside.
        for (i, p) in peeled.iter_mut().enumerate() {
            let c = [i % dims[0], (i / dims[0]) % dims[1], i / (dims[0] * dims[1])];
            let edge = (0..3).any(|a| c[a] + 1 < d || c[a] + d > dims[a]);
            *p |= deep[i] != 0 && !edge;
        }
    }
    let mut count = 0;
    for (c, p) in candidate.iter_mut().zip(&peeled) {
        if *c && *p {
            *c = false;
            count += 1;
        }
    }
    count
}

/// The 15-bit substitute of a non-candidate cell: the middle of its
/// [min, max] in fixed point over the table's range (clamped: the tables
/// clamp too).
fn substitute(b: [f32; 2], table: &Tf1d) -> u32 {
    let mid = 0.5 * (b[0] as f64 + b[1] as f64);
    let u = ((mid - table.lo as f64) / (table.hi as f64 - table.lo as f64)).clamp(0.0, 1.0);
    if u.is_nan() {
        return 0;
    }
    (u * 32767.0).round() as u32
}

/// Builds the index volume: candidates get their index within the row,
/// others `0x8000 | substitute`.
pub fn build_index(candidate: &[bool], bounds: &[[f32; 2]], dims: [usize; 3], table: &Tf1d) -> Index {
    let nx = dims[0];
    let rows = dims[1] * dims[2];
    let mut entries = vec![0u32; candidate.len()];
    let mut sat = Vec::with_capacity(rows);
    let mut cells = Vec::new();
    for r in 0..rows {
        sat.push(cells.len() as u32);
        let mut local = 0u32;
        for x in 0..nx {
            let i = r * nx + x;
            if candidate[i] {
                entries[i] = local;
                local += 1;
                cells.push(i as u32);
            } else {
                entries[i] = 0x8000 | substitute(bounds[i], table);
            }
        }
    }
    let words = entries.chunks(2).map(|p| p[0] | (p.get(1).copied().unwrap_or(0) << 16)).collect();
    Index { words, sat, cells }
}

impl Index {
    /// The slot of cell `i` as the shader finds it (None: not a candidate).
    pub fn slot(&self, i: usize, nx: usize) -> Option<u32> {
        let w = (self.words[i >> 1] >> ((i & 1) << 4)) & 0xffff;
        (w & 0x8000 == 0).then(|| self.sat[i / nx] + (w & 0x7fff))
    }
}

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

fn template(file: &'static str, name: &str) -> String {
    let mut env = minijinja::Environment::new();
    env.add_template("t", file).expect("template");
    env.get_template("t").unwrap().render(minijinja::context! { name => name }).expect("render")
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
    step: f32,
    preintegrate: bool,
    table: Vec<[f32; 4]>,
    pipeline: wgpu::ComputePipeline,
    bgl: wgpu::BindGroupLayout,
    params: wgpu::Buffer,
    /// Index volume and summed-area table.
    buffers: [wgpu::Buffer; 2],
    /// Densities and gradients.
    words: [CacheWords; 2],
}

/// One part of the cache: words in an r32uint 3D texture, word i at texel
/// (i % W, (i / W) % H, i / (W H)). A texture, not a storage buffer,
/// because storage bindings are limited (128 MiB on lavapipe and many
/// GPUs) and the densities of N = 10 exceed that on ordinary volumes.
struct CacheWords {
    texture: wgpu::Texture,
    view: wgpu::TextureView,
    extent: [u32; 3],
}

impl CacheWords {
    fn new(gpu: &Gpu, label: &str, words: u64) -> Result<CacheWords, GpuError> {
        let max = gpu.limits().max_texture_dimension_3d;
        let extent = texel_extent(words, max).ok_or_else(|| {
            GpuError::Runtime(format!(
                "--cache perm: the {label} need {words} words, more than a 3D texture of {max}^3 texels holds; use a smaller --qc or --qc-grad"
            ))
        })?;
        let texture = gpu.checked(&format!("allocate {label}"), || {
            gpu.device.create_texture(&wgpu::TextureDescriptor {
                label: Some(label),
                size: wgpu::Extent3d { width: extent[0], height: extent[1], depth_or_array_layers: extent[2] },
                mip_level_count: 1,
                sample_count: 1,
                dimension: wgpu::TextureDimension::D3,
                format: wgpu::TextureFormat::R32Uint,
                usage: wgpu::TextureUsages::STORAGE_BINDING
                    | wgpu::TextureUsages::TEXTURE_BINDING
                    | wgpu::TextureUsages::COPY_SRC,
                view_formats: &[],
            })
        })?;
        let view = texture.create_view(&wgpu::TextureViewDescriptor::default());
        Ok(CacheWords { texture, view, extent })
    }

    /// Bytes allocated.
    fn bytes(&self) -> u64 {
        self.extent.iter().map(|&e| u64::from(e)).product::<u64>() * 4
    }

    /// All words, in order (texels past the last word included).
    fn read(&self, gpu: &Gpu) -> Result<Vec<u32>, GpuError> {
        let [w, h, d] = self.extent;
        let row = u64::from(w) * 4;
        let padded = row.div_ceil(256) * 256;
        let staging = gpu.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("perm readback"),
            size: padded * u64::from(h) * u64::from(d),
            usage: wgpu::BufferUsages::COPY_SRC | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let mut enc =
            gpu.device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("perm readback") });
        enc.copy_texture_to_buffer(
            self.texture.as_image_copy(),
            wgpu::TexelCopyBufferInfo {
                buffer: &staging,
                layout: wgpu::TexelCopyBufferLayout {
                    offset: 0,
                    bytes_per_row: Some(padded as u32),
                    rows_per_image: Some(h),
                },
            },
            wgpu::Extent3d { width: w, height: h, depth_or_array_layers: d },
        );
        gpu.queue.submit([enc.finish()]);
        let bytes = gpu.read_buffer(&staging)?;
        Ok(bytes
            .chunks(padded as usize)
            .flat_map(|r| bytemuck::cast_slice::<u8, u32>(&r[..row as usize]).to_vec())
            .collect())
    }
}

/// The extent (W, H, D) of a 3D texture of at least `words` texels, no
/// side over `max`, wasting as few texels as the search finds (at most W
/// per slice; often none): the reported memory is what is allocated.
pub fn texel_extent(words: u64, max: u32) -> Option<[u32; 3]> {
    let words = words.max(1);
    let m = u64::from(max);
    let mut best: Option<(u64, [u32; 3])> = None;
    for w in (1..=m.min(words)).rev() {
        let rows = words.div_ceil(w);
        let d = rows.div_ceil(m);
        if d > m {
            break;
        }
        let h = rows.div_ceil(d);
        let total = w * h * d;
        if best.is_none_or(|(t, _)| total < t) {
            best = Some((total, [w as u32, h as u32, d as u32]));
            if total == words {
                break;
            }
        }
    }
    best.map(|(_, e)| e)
}

/// Workgroups (x, y) of 64 threads covering `threads`, and threads per row.
fn grid(threads: u64) -> ((u32, u32, u32), u32) {
    let groups = threads.div_ceil(64).max(1);
    let gx = groups.min(65535);
    ((gx as u32, groups.div_ceil(gx) as u32, 1), (gx * 64) as u32)
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
    ) -> Result<PermCache, GpuError> {
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
    ) -> Result<PermCache, GpuError> {
        let start = Instant::now();
        let (gpu, d, vol) = (scene.gpu, scene.d, scene.vol);
        let dev = &gpu.device;
        let name = &d.filter.name;
        let dims = vol.dims;
        if dims[0] > MAX_ROW {
            return Err(GpuError::Runtime(format!(
                "--cache perm: the volume is {} cells along x, over the {MAX_ROW} a 15-bit row index addresses",
                dims[0]
            )));
        }
        let layout = scene.dv.layout;
        let build_src = format!(
            "{}\n{}",
            filter_module(d, layout)?,
            template(include_str!("../../../../templates/perm_build.wgsl.j2"), name)
        );
        let build = gpu.compile(&format!("{name}.perm_build.wgsl"), &build_src)?;
        let bounds = block_bounds(gpu, &build, name, &scene.dv, dims, 1)?;
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
            return Err(GpuError::Runtime(format!(
                "--qc {} --qc-grad {}: the PERM cache of {} candidate cells needs {}, over the limit of {limit} bytes; use a smaller --qc or --qc-grad",
                quant.density,
                quant.gradient,
                counts.candidates,
                need.describe()
            )));
        }
        let binding = gpu.limits().max_storage_buffer_binding_size.min(gpu.limits().max_buffer_size);
        if need.index_volume > binding {
            return Err(GpuError::Runtime(format!(
                "--cache perm: the index volume of {} cells needs {} bytes, over this device's storage-binding limit of {binding} bytes; downsample the volume",
                counts.cells, need.index_volume
            )));
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
            entries: &[uniform_entry(0), storage_entry(1, true), storage_texture_entry(2), storage_entry(3, false)],
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
            let pipe = gpu.pipeline(entry, &build, &[&scene.bgl_s, &bgl_b], &format!("{name}_{entry}"))?;
            if threads > 0 {
                gpu.dispatch(entry, &pipe, &[&scene.bg_s, &bg], groups)?;
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
            shader_source_with(d, layout, true)?,
            template(include_str!("../../../../templates/perm.wgsl.j2"), name)
        );
        let shader = gpu.compile(&format!("{name}.dvr_perm.wgsl"), &render_src)?;
        let mut entries = caster_entries();
        entries.extend([
            uniform_entry(5),
            storage_entry(6, true),
            storage_entry(7, true),
            texture_entry(8),
            texture_entry(9),
        ]);
        let bgl = dev
            .create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor { label: Some("dvr perm"), entries: &entries });
        let pipeline = gpu.pipeline("dvr perm", &shader, &[&scene.bgl_s, &bgl], &format!("{name}_dvr_main"))?;
        let params = PermParams {
            dims: [dims[0] as i32, dims[1] as i32, dims[2] as i32, 0],
            quant: [quant.density, quant.gradient, n3 as u32, m3 as u32],
            scale: [table.lo, span / 65535.0, span / 32767.0, gmax / 255.0],
            tex: [db.extent[0], db.extent[1], gb.extent[0], gb.extent[1]],
        };
        let params = dev.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("perm params"),
            contents: bytemuck::bytes_of(&params),
            usage: wgpu::BufferUsages::UNIFORM,
        });
        let g = gb.bytes();
        let memory = Memory {
            index_volume: iv.size(),
            summed_area: sat.size(),
            density: db.bytes(),
            gradient: g / 4 * 3,
            sign: g / 4,
        };
        Ok(PermCache {
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
        })
    }

    /// The densities as stored (16-bit fixed point, decoded to values).
    pub fn densities(&self, gpu: &Gpu, table: &Tf1d) -> Result<Vec<f32>, GpuError> {
        let words = self.words[0].read(gpu)?;
        let unit = (table.hi - table.lo) / 65535.0;
        let n = self.counts.candidates as usize * self.counts.quant.density.pow(3) as usize;
        Ok((0..n).map(|m| table.lo + unit * ((words[m >> 1] >> ((m & 1) << 4)) & 0xffff) as f32).collect())
    }

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
) -> Result<(Frame, PermCache), GpuError> {
    let scene = DvrScene::new(gpu, d, vol, layout, o.block)?;
    let table = tf.table();
    let pi = o.preintegrate.then(|| table.preintegrate(o.step as f64));
    let termination = peel.then_some(o.termination);
    let cache = PermCache::build_peeled(&scene, &table, quant, o.step, o.preintegrate, termination)?;
    let frame = cache.render(&scene, &table, pi.as_ref(), o)?;
    Ok((frame, cache))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bad_requests_are_refused_with_the_flag_named() {
        assert_eq!(check_request("none", "dvr", None, None), Ok(None));
        assert_eq!(check_request("perm", "dvr", None, None), Ok(Some(Quant { density: 5, gradient: 5 })));
        assert_eq!(check_request("perm", "dvr", Some(5), Some(3)), Ok(Some(Quant { density: 5, gradient: 3 })));
        for (cache, mode, qc, qg, fragment) in [
            ("perm", "dvr", Some(0), None, "--qc 0"),
            ("perm", "dvr", Some(4), Some(0), "--qc-grad 0"),
            ("perm", "dvr", Some(1000), None, "over the limit of 2147483648 bytes"),
            ("perm", "iso", None, None, "--mode iso"),
            ("lru", "dvr", None, None, "--cache lru"),
            ("none", "dvr", Some(5), None, "add --cache perm"),
        ] {
            let e = check_request(cache, mode, qc, qg).unwrap_err();
            assert!(e.contains(fragment) && !e.contains('\n'), "{e}");
        }
        // The refusal names the bytes: 1000^3 x 2 + 1000^3 x 4.
        assert!(check_request("perm", "dvr", Some(1000), None).unwrap_err().contains("6000000000 bytes"));
        // The largest accepted N is the one the message suggests.
        let e = check_request("perm", "dvr", Some(1000), None).unwrap_err();
        let largest: u32 = e.rsplit("--qc ").next().unwrap().split(' ').next().unwrap().parse().unwrap();
        assert!(check_request("perm", "dvr", Some(largest), None).is_ok());
        assert!(check_request("perm", "dvr", Some(largest + 1), None).is_err());
    }

    #[test]
    fn the_index_finds_every_candidate_and_keeps_substitutes_transparent() {
        let tf = TransferFunction::parse(
            r#"{"range": [0, 1], "points": [{"value": 0, "color": [0, 0, 0], "opacity": 0},
                {"value": 0.3, "color": [0, 0, 0], "opacity": 0}, {"value": 0.5, "color": [1, 1, 1], "opacity": 0.8}]}"#,
            "t",
        )
        .unwrap()
        .table();
        let dims = [5, 3, 2];
        // Cell bounds: a visible cell at (2, 1, 1), everything else clear.
        let mut bounds = vec![[0.0f32, 0.05]; 30];
        bounds[2 + 5 * (1 + 3)] = [0.2, 0.8];
        let (visible, candidate) = select_cells(&bounds, dims, &tf, 1);
        assert_eq!(visible.iter().filter(|&&v| v).count(), 1);
        // Brute-force dilation.
        for z in 0..2i32 {
            for y in 0..3i32 {
                for x in 0..5i32 {
                    let near = (x - 2).abs() <= 1 && (y - 1).abs() <= 1 && (z - 1).abs() <= 1;
                    assert_eq!(candidate[(x + 5 * (y + 3 * z)) as usize], near, "({x}, {y}, {z})");
                }
            }
        }
        let index = build_index(&candidate, &bounds, dims, &tf);
        let mut seen = vec![];
        for (i, &c) in candidate.iter().enumerate() {
            match index.slot(i, 5) {
                Some(s) => {
                    assert!(c);
                    assert_eq!(index.cells[s as usize], i as u32);
                    seen.push(s);
                }
                None => {
                    assert!(!c);
                    let w = (index.words[i >> 1] >> ((i & 1) << 4)) & 0x7fff;
                    let v = tf.lo + (tf.hi - tf.lo) * w as f32 / 32767.0;
                    assert!((v - 0.025).abs() < 1e-4 && tf.transparent(v as f64, v as f64));
                }
            }
        }
        seen.sort();
        assert_eq!(seen, (0..index.cells.len() as u32).collect::<Vec<_>>(), "slots are 0..N_cc, each once");
    }

    #[test]
    fn texture_extents_hold_every_word_and_waste_little() {
        for (words, max) in
            [(1u64, 2048u32), (5, 2048), (2049, 2048), (4096 * 4097, 2048), (1 << 29, 2048), (99_991, 64), (4093, 16)]
        {
            let e = texel_extent(words, max).unwrap();
            let total: u64 = e.iter().map(|&v| u64::from(v)).product();
            assert!(e.iter().all(|&v| v >= 1 && v <= max), "{words}: {e:?}");
            assert!(total >= words, "{words}: {e:?} holds {total}");
            // At most one row per slice is partly empty.
            assert!(total - words < u64::from(e[0]) * u64::from(e[2]), "{words}: {e:?} wastes {}", total - words);
        }
        // 2^29 words fill 2048 x 2048 x 128 exactly; a prime count fits exactly in one row when it can.
        assert_eq!(texel_extent(1 << 29, 2048), Some([2048, 2048, 128]));
        assert_eq!(texel_extent(2039, 2048), Some([2039, 1, 1]));
        // Too many words for the largest texture.
        assert_eq!(texel_extent(16 * 16 * 16 + 1, 16), None);
    }

    #[test]
    fn peeling_drops_exactly_the_cells_deeper_than_the_bound() {
        // A table whose values above 0.5 have extinction 1.5 per cell, below clear.
        let tf = TransferFunction::parse(
            r#"{"range": [0, 1], "points": [{"value": 0, "color": [0, 0, 0], "opacity": 0},
                {"value": 0.49, "color": [1, 1, 1], "opacity": 0}, {"value": 0.51, "color": [1, 1, 1], "opacity": 0.7769},
                {"value": 1, "color": [1, 1, 1], "opacity": 0.7769}]}"#,
            "t",
        )
        .unwrap()
        .table();
        let dims = [30usize, 28, 26];
        let n: usize = dims.iter().product();
        let cell = |i: usize| [i % dims[0], (i / dims[0]) % dims[1], i / (dims[0] * dims[1])];
        // A solid box [4, 24)^3 of value 0.8, clear elsewhere.
        let solid = |c: [usize; 3]| (0..3).all(|a| (4..24).contains(&c[a]));
        let bounds: Vec<[f32; 2]> = (0..n).map(|i| if solid(cell(i)) { [0.8, 0.8] } else { [0.0, 0.0] }).collect();
        let tau = tf.entries.iter().map(|e| e[3]).fold(0.0f32, f32::max) as f64;
        assert!((tau - 1.5).abs() < 0.01, "extinction {tau}");
        for (step, termination) in [(0.5f32, 0.99f32), (1.0, 0.9)] {
            let mut candidate = vec![true; n];
            let peeled = peel(&bounds, dims, &tf, step, termination, &mut candidate);
            // Brute force: the tau of a cell is over its hull (reach ceil(step)), so
            // a cell is in R when every cell within ceil(step) is solid; the bound
            // asks for radius d - 1 of R around it, d = ceil(1 + 3 step + D / tau).
            let reach = step.ceil() as i64;
            let d = (1.0 + 3.0 * step as f64 - (1.0 - termination as f64).ln() / tau).ceil() as i64;
            let depth_ok = |c: [usize; 3]| {
                // distance from c to the nearest non-solid cell (outside the volume included), Chebyshev
                let to_clear = (0..3).map(|a| (c[a] as i64 - 3).min(24 - c[a] as i64)).min().unwrap();
                to_clear > d - 1 + reach
            };
            let mut want = 0;
            for (i, &c) in candidate.iter().enumerate() {
                let expect = depth_ok(cell(i));
                want += expect as u64;
                assert_eq!(!c, expect, "cell {:?}, step {step}, termination {termination}", cell(i));
            }
            assert!(peeled == want && peeled > 0, "{peeled} vs {want}");
        }
        // A translucent box proves nothing deep enough: nothing is peeled.
        let faint: Vec<[f32; 2]> = bounds.iter().map(|b| [b[0] * 0.62, b[1] * 0.62]).collect();
        let mut candidate = vec![true; n];
        assert_eq!(peel(&faint, dims, &tf, 0.5, 0.99, &mut candidate), 0);
    }

    #[test]
    fn the_formula_is_equation_six() {
        let c = Counts { cells: 1000, rows: 100, candidates: 10, quant: Quant { density: 5, gradient: 3 } };
        let m = formula(&c);
        assert_eq!(m.total(), 1000 * 2 + 100 * 4 + 10 * 125 * 2 + 10 * 27 * 3 + 10 * 27);
    }
}
