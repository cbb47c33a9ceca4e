//! The host side of projected tetrahedra (`render --renderer pt`): per-cell
//! visibility masks from the transfer function, the back-to-front order of
//! the visible tetrahedra ([`Complexes::visible_back_to_front`]), and one
//! instanced draw of the render pipeline of `templates/pt.wgsl` (12 vertices
//! per tetrahedron) into an Rgba16Float target cleared to the ray caster's
//! background, blended "over" (premultiplied), then read back as RGBA8 like
//! the ray caster's image. Orthographic views only: the implicit traversal
//! order is a visibility order for parallel projection (the paper's case);
//! a perspective request is refused with that reason.

use super::tets::{inverse_edges, Complexes, Grid};
use crate::gpu::binding::{storage_entry, uniform_entry};
use crate::gpu::{Gpu, GpuError};
use crate::render::camera::CameraUniform;
use crate::render::dvr::transfer::TransferFunction;
use crate::render::dvr::{DvrOptions, BACKGROUND, G0_OF_RANGE, LIGHT};
use crate::render::iso::{ray_params, Frame, RenderOptions};
use crate::volume::LatticeVolume;
use boxforge::derive::Derivation;
use std::time::Instant;

/// How the tetrahedra are shaded (the paper's two options).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Shading {
    /// Lighting at the vertices, interpolated.
    Gouraud,
    /// The normal interpolated, lighting per fragment.
    Phong,
}

/// Which normals the shading uses.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Normals {
    /// The interpolant's own gradient, constant on each tetrahedron: what
    /// the ray caster's `eval_grad` gives for the linear box spline (the two
    /// shadings then coincide).
    Cell,
    /// Smooth normals at the vertices (least-squares gradient of the
    /// nearest samples), as the paper shades: Gouraud and Phong differ.
    Vertex,
}

/// The uniform block of `templates/pt.wgsl` (`PtParams`, 12 vec4).
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
pub struct PtParams {
    /// Eye, view and valid box, as [`crate::render::iso::RayParams`]'s.
    pub camera: CameraUniform,
    /// Table lo, unused, (n_pi - 1) / (hi - lo), step.
    pub tf: [f32; 4],
    /// Ambient, diffuse, specular, g0.
    pub light: [f32; 4],
    /// Width, height, shading (0 Gouraud, 1 Phong), normals (0 the cell's gradient).
    pub image: [i32; 4],
    /// nx, ny, nz, grid (0 BCC, 1 CC).
    pub dims: [i32; 4],
    /// Complexes per axis, spacing of their base points.
    pub counts: [i32; 4],
    /// Base point of complex 0, pre-integration entries per axis.
    pub origin: [i32; 4],
}

/// What a projected-tetrahedra image cost.
#[derive(Clone, Debug)]
pub struct PtStats {
    /// Tetrahedra drawn (visible under the transfer function) and in the mesh.
    pub drawn: usize,
    pub total: usize,
    /// CPU time for the masks and the sort, ms.
    pub order_ms: f64,
}

/// Per complex, bit t set when tetrahedron type t is visible: the transfer
/// function is not transparent over [min, max] of its four vertex values
/// (the linear interpolant stays inside that range).
pub fn visibility_masks(c: &Complexes, vol: &LatticeVolume, table: &crate::render::dvr::transfer::Tf1d) -> Vec<u16> {
    let types = c.grid.types();
    let at = |j: [i64; 3]| {
        let k = [0, 1, 2].map(|a| j[a].clamp(0, vol.dims[a] as i64 - 1) as usize);
        vol.data[k[0] + vol.dims[0] * (k[1] + vol.dims[1] * k[2])] as f64
    };
    (0..c.len())
        .map(|i| {
            let b = c.base(i);
            let mut m = 0u16;
            for (t, ty) in types.iter().enumerate() {
                let vals = ty.map(|o| at([b[0] + o[0], b[1] + o[1], b[2] + o[2]]));
                let lo = vals.iter().copied().fold(f64::INFINITY, f64::min);
                let hi = vals.iter().copied().fold(f64::NEG_INFINITY, f64::max);
                if !table.transparent(lo, hi) {
                    m |= 1 << t;
                }
            }
            m
        })
        .collect()
}

/// The samples as the shader's `DATA` holds them: CC as they are; BCC only
/// the lattice points, the all-even then the all-odd ones, each a grid of
/// ceil(n / 2) per axis, x fastest (a quarter of the embedded size, which
/// keeps a 1 mm head under the 128 MiB storage-binding limit).
pub fn packed_data(vol: &LatticeVolume, grid: Grid) -> Vec<f32> {
    if grid == Grid::Cc {
        return vol.data.clone();
    }
    let [nx, ny, nz] = vol.dims;
    let h = [nx.div_ceil(2), ny.div_ceil(2), nz.div_ceil(2)];
    let mut out = vec![0f32; 2 * h[0] * h[1] * h[2]];
    for parity in 0..2 {
        for z in 0..h[2] {
            for y in 0..h[1] {
                for x in 0..h[0] {
                    let j = [2 * x + parity, 2 * y + parity, 2 * z + parity];
                    if j[0] < nx && j[1] < ny && j[2] < nz {
                        out[parity * h[0] * h[1] * h[2] + (z * h[1] + y) * h[0] + x] =
                            vol.data[j[0] + nx * (j[1] + ny * j[2])];
                    }
                }
            }
        }
    }
    out
}

/// f16 bits to f32 (the render target's texels).
fn half_to_f32(h: u16) -> f32 {
    let sign = if h & 0x8000 != 0 { -1.0 } else { 1.0 };
    let exp = ((h >> 10) & 0x1f) as i32;
    let frac = (h & 0x3ff) as f32;
    match exp {
        0 => sign * frac * 2f32.powi(-24),
        31 => f32::NAN,
        e => sign * (1.0 + frac / 1024.0) * 2f32.powi(e - 15),
    }
}

/// One projected-tetrahedra image of `vol` (BCC or CC data) with transfer
/// function `tf`, pre-integrated for `o.step`; `d` is the filter whose valid
/// box clips the segments (the ray caster's, so both show the same region).
pub fn render(
    gpu: &Gpu,
    d: &Derivation,
    vol: &LatticeVolume,
    tf: &TransferFunction,
    o: &DvrOptions,
    shading: Shading,
    normals: Normals,
) -> Result<(Frame, PtStats), GpuError> {
    let grid = Grid::of(&vol.lattice).ok_or_else(|| {
        GpuError::Runtime(format!(
            "projected tetrahedra need BCC or CC data, not the {} lattice: use the ray caster",
            vol.lattice.name
        ))
    })?;
    if o.perspective {
        return Err(GpuError::Runtime(
            "projected tetrahedra here are orthographic (the implicit back-to-front traversal is a visibility order only for parallel projection): render a parallel view or use the ray caster".into(),
        ));
    }
    let started = Instant::now();
    let table = tf.table();
    let pi = table.preintegrate(o.step as f64);
    let complexes = Complexes::cover(grid, vol.dims);
    let masks = visibility_masks(&complexes, vol, &table);
    let r = ray_params(
        d,
        vol,
        &RenderOptions {
            width: o.width,
            height: o.height,
            azimuth: o.azimuth,
            elevation: o.elevation,
            perspective: false,
            ..RenderOptions::default()
        },
    );
    let forward = [r.camera.forward[0] as f64, r.camera.forward[1] as f64, r.camera.forward[2] as f64];
    let ids = complexes.visible_back_to_front(&masks, forward);
    let order_ms = started.elapsed().as_secs_f64() * 1e3;
    let types = grid.types();
    let type_words: Vec<[i32; 4]> =
        types.iter().flat_map(|t| t.map(|v| [v[0] as i32, v[1] as i32, v[2] as i32, 0])).collect();
    let inv_words: Vec<[f32; 4]> = types
        .iter()
        .flat_map(|t| inverse_edges(t).map(|row| [row[0] as f32, row[1] as f32, row[2] as f32, 0.0]))
        .collect();
    let span = table.hi - table.lo;
    let params = PtParams {
        camera: r.camera,
        tf: [table.lo, 0.0, (pi.size as f32 - 1.0) / span, o.step],
        light: [LIGHT[0], LIGHT[1], LIGHT[2], G0_OF_RANGE * span],
        image: [
            o.width as i32,
            o.height as i32,
            (shading == Shading::Phong) as i32,
            (normals == Normals::Vertex) as i32,
        ],
        dims: [vol.dims[0] as i32, vol.dims[1] as i32, vol.dims[2] as i32, (grid == Grid::Cc) as i32],
        counts: [
            complexes.counts[0] as i32,
            complexes.counts[1] as i32,
            complexes.counts[2] as i32,
            grid.spacing() as i32,
        ],
        origin: [complexes.origin[0] as i32, complexes.origin[1] as i32, complexes.origin[2] as i32, pi.size as i32],
    };

    let dev = &gpu.device;
    let shader = gpu.compile("pt.wgsl", super::SHADER)?;
    let entries: Vec<wgpu::BindGroupLayoutEntry> = (0..6)
        .map(|b| {
            let mut e = if b == 0 { uniform_entry(0) } else { storage_entry(b, true) };
            e.visibility = wgpu::ShaderStages::VERTEX_FRAGMENT;
            e
        })
        .collect();
    let bgl = dev.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor { label: Some("pt"), entries: &entries });
    let layout = dev.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
        label: Some("pt"),
        bind_group_layouts: &[Some(&bgl)],
        immediate_size: 0,
    });
    let format = wgpu::TextureFormat::Rgba16Float;
    // Premultiplied "over": what is drawn later (nearer) covers what lies behind.
    let over = wgpu::BlendComponent {
        src_factor: wgpu::BlendFactor::One,
        dst_factor: wgpu::BlendFactor::OneMinusSrcAlpha,
        operation: wgpu::BlendOperation::Add,
    };
    let pipeline = gpu.checked("pt pipeline", || {
        dev.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
            label: Some("pt"),
            layout: Some(&layout),
            vertex: wgpu::VertexState {
                module: &shader,
                entry_point: Some("pt_vs"),
                compilation_options: Default::default(),
                buffers: &[],
            },
            primitive: wgpu::PrimitiveState {
                topology: wgpu::PrimitiveTopology::TriangleList,
                cull_mode: None,
                ..Default::default()
            },
            depth_stencil: None,
            multisample: wgpu::MultisampleState::default(),
            fragment: Some(wgpu::FragmentState {
                module: &shader,
                entry_point: Some("pt_fs"),
                compilation_options: Default::default(),
                targets: &[Some(wgpu::ColorTargetState {
                    format,
                    blend: Some(wgpu::BlendState { color: over, alpha: over }),
                    write_mask: wgpu::ColorWrites::ALL,
                })],
            }),
            multiview_mask: None,
            cache: None,
        })
    })?;
    let data = packed_data(vol, grid);
    let limit = gpu.limits().max_storage_buffer_binding_size.min(gpu.limits().max_buffer_size);
    for (what, bytes) in [("samples", data.len() * 4), ("visible tetrahedra", ids.len() * 4)] {
        if bytes as u64 > limit {
            return Err(GpuError::Runtime(format!(
                "projected tetrahedra: the {what} take {bytes} bytes, over this adapter's storage-binding limit of {limit}: use a smaller volume (e.g. resampled from a downsampled file) or the ray caster"
            )));
        }
    }
    let ids_or_one = if ids.is_empty() { vec![0u32] } else { ids.clone() };
    let buffers = [
        gpu.uniform_buffer("pt params", bytemuck::bytes_of(&params)),
        gpu.storage_buffer("pt data", bytemuck::cast_slice(&data), false),
        gpu.storage_buffer("pt types", bytemuck::cast_slice(&type_words), false),
        gpu.storage_buffer("pt inverse edges", bytemuck::cast_slice(&inv_words), false),
        gpu.storage_buffer("pt ids", bytemuck::cast_slice(&ids_or_one), false),
        gpu.storage_buffer("pt preint", bytemuck::cast_slice(&pi.entries), false),
    ];
    let bind_entries: Vec<wgpu::BindGroupEntry> = buffers
        .iter()
        .enumerate()
        .map(|(b, buf)| wgpu::BindGroupEntry { binding: b as u32, resource: buf.as_entire_binding() })
        .collect();
    let bg =
        dev.create_bind_group(&wgpu::BindGroupDescriptor { label: Some("pt"), layout: &bgl, entries: &bind_entries });
    let size = wgpu::Extent3d { width: o.width, height: o.height, depth_or_array_layers: 1 };
    let target = dev.create_texture(&wgpu::TextureDescriptor {
        label: Some("pt target"),
        size,
        mip_level_count: 1,
        sample_count: 1,
        dimension: wgpu::TextureDimension::D2,
        format,
        usage: wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::COPY_SRC,
        view_formats: &[],
    });
    let view = target.create_view(&Default::default());
    let row_bytes = (o.width * 8).next_multiple_of(wgpu::COPY_BYTES_PER_ROW_ALIGNMENT);
    let readback = dev.create_buffer(&wgpu::BufferDescriptor {
        label: Some("pt readback"),
        size: (row_bytes * o.height) as u64,
        usage: wgpu::BufferUsages::COPY_SRC | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    let mut times = Vec::new();
    for frame in 0..=o.frames {
        let t0 = Instant::now();
        let mut enc = dev.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("pt") });
        {
            let mut pass = enc.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("pt"),
                color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                    view: &view,
                    depth_slice: None,
                    resolve_target: None,
                    ops: wgpu::Operations {
                        load: wgpu::LoadOp::Clear(wgpu::Color {
                            r: BACKGROUND[0],
                            g: BACKGROUND[1],
                            b: BACKGROUND[2],
                            a: 1.0,
                        }),
                        store: wgpu::StoreOp::Store,
                    },
                })],
                depth_stencil_attachment: None,
                timestamp_writes: None,
                occlusion_query_set: None,
                multiview_mask: None,
            });
            pass.set_pipeline(&pipeline);
            pass.set_bind_group(0, &bg, &[]);
            if !ids.is_empty() {
                pass.draw(0..12, 0..ids.len() as u32);
            }
        }
        enc.copy_texture_to_buffer(
            wgpu::TexelCopyTextureInfo {
                texture: &target,
                mip_level: 0,
                origin: wgpu::Origin3d::ZERO,
                aspect: wgpu::TextureAspect::All,
            },
            wgpu::TexelCopyBufferInfo {
                buffer: &readback,
                layout: wgpu::TexelCopyBufferLayout {
                    offset: 0,
                    bytes_per_row: Some(row_bytes),
                    rows_per_image: Some(o.height),
                },
            },
            size,
        );
        gpu.queue.submit([enc.finish()]);
        gpu.wait()?;
        if frame > 0 {
            times.push(t0.elapsed().as_secs_f64() * 1e3);
        }
    }
    let raw = gpu.read_buffer(&readback)?;
    let mut rgba = Vec::with_capacity((o.width * o.height * 4) as usize);
    for y in 0..o.height as usize {
        let row = &raw[y * row_bytes as usize..][..o.width as usize * 8];
        for px in row.chunks_exact(8) {
            for c in 0..3 {
                let v = half_to_f32(u16::from_le_bytes([px[2 * c], px[2 * c + 1]]));
                rgba.push((v.clamp(0.0, 1.0) * 255.0 + 0.5) as u8);
            }
            rgba.push(255);
        }
    }
    times.sort_by(f64::total_cmp);
    let ms = times.get(times.len() / 2).copied().unwrap_or(f64::NAN);
    let total = complexes.len() * types.len();
    Ok((
        Frame {
            width: o.width,
            height: o.height,
            rgba,
            ms_per_frame: ms,
            empty_blocks: 1.0 - ids.len() as f64 / total.max(1) as f64,
        },
        PtStats { drawn: ids.len(), total, order_ms },
    ))
}

#[cfg(test)]
mod tests {
    use super::{half_to_f32, PtParams};
    use crate::render::camera::CameraUniform;
    use crate::render::dvr::DvrParams;
    use crate::render::iso::RayParams;
    use std::mem::{offset_of, size_of};

    #[test]
    fn halves_decode() {
        assert_eq!(half_to_f32(0x3c00), 1.0);
        assert_eq!(half_to_f32(0x3800), 0.5);
        assert_eq!(half_to_f32(0xc000), -2.0);
        assert_eq!(half_to_f32(0x0001), 2f32.powi(-24));
        assert_eq!(half_to_f32(0x7bff), 65504.0);
    }

    /// The field names of `struct <name>` in a template, checking that each
    /// is a vec4 (16 bytes, so offsets are 16 x position, no padding).
    fn vec4_fields(template: &str, name: &str) -> Vec<String> {
        let body = template.split(&format!("struct {name} {{")).nth(1).unwrap().split('}').next().unwrap();
        let fields: Vec<&str> = body.lines().map(str::trim).filter(|l| !l.is_empty() && !l.starts_with("//")).collect();
        assert!(fields.iter().all(|f| f.ends_with("vec4<f32>,") || f.ends_with("vec4<i32>,")), "{name}: {fields:?}");
        fields.iter().map(|f| f.split(':').next().unwrap().to_string()).collect()
    }

    #[test]
    fn every_uniform_block_starts_with_the_camera_block() {
        assert_eq!(size_of::<CameraUniform>(), 6 * 16);
        let camera = ["eye", "forward", "right", "up", "box_lo", "box_hi"];
        let raycast = include_str!("../../../../templates/raycast.wgsl.j2");
        let dvr = include_str!("../../../../templates/dvr.wgsl.j2");
        for (template, name, offset, size) in [
            (raycast, "{{ name }}_RayParams", offset_of!(RayParams, camera), size_of::<RayParams>()),
            (dvr, "{{ name }}_DvrParams", offset_of!(DvrParams, camera), size_of::<DvrParams>()),
            (super::super::SHADER, "PtParams", offset_of!(PtParams, camera), size_of::<PtParams>()),
        ] {
            let fields = vec4_fields(template, name);
            assert_eq!(fields[..6], camera, "{name}");
            assert_eq!(offset, 0, "{name}");
            assert_eq!(fields.len() * 16, size, "{name}");
        }
    }
}
