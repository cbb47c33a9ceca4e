//! What projected tetrahedra put on the device: the shading options, the
//! uniform block of `templates/pt.wgsl`, the per-cell visibility masks from
//! the transfer function, and the samples as its `DATA` holds them. Both the
//! per-frame [`super::PtRenderer`] and the one-shot [`super::render`] use
//! them (a module of its own, so neither imports the other).

use super::tets::{Complexes, Grid};
use crate::render::camera::CameraUniform;
use crate::volume::LatticeVolume;

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
