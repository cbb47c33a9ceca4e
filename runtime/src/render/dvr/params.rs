//! The uniform block of the DVR template and its values.

use super::{DvrOptions, G0_OF_RANGE, LIGHT};
use crate::render::camera::CameraUniform;
use crate::render::dvr::transfer::Tf1d;
use crate::render::iso::ray_params_for;
use crate::volume::LatticeVolume;
use boxforge::derive::Derivation;

/// The uniform block of `templates/dvr.wgsl.j2` (`<f>_DvrParams`).
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
pub struct DvrParams {
    /// Eye, view and valid box, as [`crate::render::iso::RayParams`]'s.
    pub camera: CameraUniform,
    /// Table lo, (n_tf - 1) / (hi - lo), (n_pi - 1) / (hi - lo), step.
    pub tf: [f32; 4],
    /// Perspective, skip, pre-integrated (0/1), termination opacity.
    pub mode: [f32; 4],
    /// Ambient, diffuse, specular, g0.
    pub light: [f32; 4],
    /// Width, height, block edge, first row of the dispatch.
    pub image: [i32; 4],
    /// Blocks per axis, 1D table entries.
    pub blocks: [i32; 4],
    /// Pre-integration entries per axis.
    pub sizes: [i32; 4],
}

/// The uniform values of a DVR image.
pub fn dvr_params(d: &Derivation, vol: &LatticeVolume, table: &Tf1d, pi_size: usize, o: &DvrOptions) -> DvrParams {
    dvr_params_for(crate::volume::support_radius(d), vol.dims, table, pi_size, o)
}

/// [`dvr_params`] for a volume of `dims` samples and a filter whose support
/// reaches `radius` cells (what a renderer keeps after the upload).
pub(crate) fn dvr_params_for(
    radius: usize,
    dims: [usize; 3],
    table: &Tf1d,
    pi_size: usize,
    o: &DvrOptions,
) -> DvrParams {
    let r = ray_params_for(radius, dims, &o.camera());
    let span = table.hi - table.lo;
    DvrParams {
        camera: r.camera,
        tf: [table.lo, (table.entries.len() as f32 - 1.0) / span, (pi_size as f32 - 1.0) / span, o.step],
        mode: [o.perspective as i32 as f32, o.skip as i32 as f32, o.preintegrate as i32 as f32, o.termination],
        light: [LIGHT[0], LIGHT[1], LIGHT[2], G0_OF_RANGE * span],
        image: [o.width as i32, o.height as i32, o.block, 0],
        blocks: [r.blocks[0], r.blocks[1], r.blocks[2], table.entries.len() as i32],
        sizes: [pi_size as i32, 0, 0, 0],
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::render::dvr::dvr_template;

    #[test]
    fn the_uniform_matches_the_template_struct() {
        // Every field of `<f>_DvrParams` is a vec4 (16 bytes, no padding), in
        // the order of DvrParams.
        let t = dvr_template("f", false);
        let body = t.split("struct f_DvrParams {").nth(1).unwrap().split('}').next().unwrap();
        let fields: Vec<&str> = body.lines().map(str::trim).filter(|l| !l.is_empty() && !l.starts_with("//")).collect();
        assert!(fields.iter().all(|f| f.ends_with("vec4<f32>,") || f.ends_with("vec4<i32>,")), "{fields:?}");
        assert_eq!(fields.len() * 16, std::mem::size_of::<DvrParams>());
        let names: Vec<&str> = fields.iter().map(|f| f.split(':').next().unwrap()).collect();
        assert_eq!(
            names,
            ["eye", "forward", "right", "up", "box_lo", "box_hi", "tf", "mode", "light", "image", "blocks", "sizes"]
        );
    }
}
