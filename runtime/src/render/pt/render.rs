//! The one-shot image of projected tetrahedra (`render --renderer pt`): a
//! [`PtRenderer`] (the back-to-front order of the visible tetrahedra,
//! [`super::tets::Complexes::visible_back_to_front`], one instanced draw of
//! 12 vertices per tetrahedron into an Rgba16Float image cleared to the ray
//! caster's background, blended "over") built for the call, its frame read
//! back as RGBA8 like the ray caster's image. Orthographic views only: the
//! implicit traversal order is a visibility order for parallel projection
//! (the paper's case); a perspective request is refused with that reason.
//! What it uploads is in [`super::data`] (re-exported here).

pub use super::data::{packed_data, visibility_masks, Normals, PtParams, PtStats, Shading};
use super::renderer::{PtOptions, PtRenderer};
use super::tets::Grid;
use crate::gpu::Gpu;
use crate::render::camera::Camera;
use crate::render::dvr::transfer::TransferFunction;
use crate::render::dvr::DvrOptions;
use crate::render::iso::Frame;
use crate::render::RenderError;
use crate::volume::LatticeVolume;
use boxforge::derive::Derivation;

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
) -> Result<(Frame, PtStats), RenderError> {
    if Grid::of(&vol.lattice).is_none() {
        return Err(RenderError::PtLattice { lattice: vol.lattice.name.clone() });
    }
    if o.perspective {
        return Err(RenderError::PtPerspective);
    }
    let options = PtOptions { step: o.step, shading, normals };
    let mut renderer = PtRenderer::new(gpu, d, vol, tf, options)?;
    let camera = Camera { azimuth: o.azimuth, elevation: o.elevation, perspective: false };
    let frame = renderer.timed_frames(o.width, o.height, &camera, o.frames)?;
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
        let (raycast, dvr) = (crate::render::templates::RAYCAST, crate::render::templates::DVR);
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
