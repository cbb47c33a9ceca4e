//! The host side of projected tetrahedra (`render --renderer pt`): per-cell
//! visibility masks from the transfer function, the uniform block of
//! `templates/pt.wgsl`, the samples as its `DATA` holds them, and the
//! one-shot image: a [`PtRenderer`] (the back-to-front order of the visible
//! tetrahedra, [`Complexes::visible_back_to_front`], one instanced draw of
//! 12 vertices per tetrahedron into an Rgba16Float image cleared to the ray
//! caster's background, blended "over") built for the call, its frame read
//! back as RGBA8 like the ray caster's image. Orthographic views only: the
//! implicit traversal order is a visibility order for parallel projection
//! (the paper's case); a perspective request is refused with that reason.

use super::renderer::{PtOptions, PtRenderer};
use super::tets::{Complexes, Grid};
use crate::gpu::{Gpu, GpuError};
use crate::render::camera::{Camera, CameraUniform};
use crate::render::dvr::transfer::TransferFunction;
use crate::render::dvr::DvrOptions;
use crate::render::iso::Frame;
use crate::render::RenderError;
use crate::volume::LatticeVolume;
use boxforge::derive::Derivation;

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

/// One projected-tetrahedra image of `vol` (BCC or CC data) with transfer
/// function `tf`, pre-integrated for `o.step`, through a [`PtRenderer`]
/// built for the call; `d` is the filter whose valid box clips the
/// segments (the ray caster's, so both show the same region).
pub fn render(
    gpu: &Gpu,
    d: &Derivation,
    vol: &LatticeVolume,
    tf: &TransferFunction,
    o: &DvrOptions,
    shading: Shading,
    normals: Normals,
) -> Result<(Frame, PtStats), GpuError> {
    if Grid::of(&vol.lattice).is_none() {
        return Err(RenderError::PtLattice { lattice: vol.lattice.name.clone() }.into_gpu());
    }
    if o.perspective {
        return Err(RenderError::PtPerspective.into_gpu());
    }
    let options = PtOptions { step: o.step, shading, normals };
    let mut renderer = PtRenderer::new(gpu, d, vol, tf, options).map_err(RenderError::into_gpu)?;
    let camera = Camera { azimuth: o.azimuth, elevation: o.elevation, perspective: false };
    let frame = renderer.timed_frames(o.width, o.height, &camera, o.frames).map_err(RenderError::into_gpu)?;
    Ok((frame, PtStats { drawn: renderer.drawn(), total: renderer.total(), order_ms: renderer.order_ms() }))
}

#[cfg(test)]
mod tests {
    use super::PtParams;
    use crate::render::camera::CameraUniform;
    use crate::render::dvr::DvrParams;
    use crate::render::iso::RayParams;
    use std::mem::{offset_of, size_of};

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
