//! Mattausch et al.'s plane-stack schemes on BCC, ray cast (`render --mode
//! dvr --filter mattausch_bilinear | mattausch_bilinear_spatial`).
//!
//! Neither scheme is a box spline of the catalog (see
//! runtime/references/mattausch_bilinear.wgsl, where they are written once
//! by hand with their source cited), so the DVR ray caster runs them through
//! `DvrScene::with_source`: the `bcc_linear` module supplies the clamped
//! texel load and the min/max kernel, the reference supplies the
//! evaluation, and a small adapter here gives it the `<name>_eval_grad` the
//! DVR template calls. As in the paper, the plane stack is chosen from the
//! view direction, once per frame: the stack whose planes are most nearly
//! perpendicular to the view (the axis of the view's largest component).
//!
//! The gradient (for shading only) is central differences of the scheme
//! with half a plane spacing; the value is the scheme's, exactly. Each
//! value is a convex combination of samples within two units (Chebyshev)
//! of the point, so a block's bound is the union of `bcc_linear`'s cell
//! bounds (an interpolant: its bound over a cell holds the cell's corner
//! samples) over the block and [`REACH`] cells around it
//! ([`crate::render::dvr::widen_bounds`]), which keeps empty-space skipping exact.

use crate::gpu::Gpu;
use crate::references::MATTAUSCH_BILINEAR;
use crate::render::dvr::caster::look_of;
use crate::render::dvr::transfer::TransferFunction;
use crate::render::dvr::{dvr_template, filter_module, Custom, DvrOptions, DvrScene};
use crate::render::iso::Frame;
use crate::render::RenderError;
use crate::volume::{DeviceVolume, LatticeVolume};
use boxforge::derive::Derivation;
use boxforge::emit::Layout;

mod renderer;

pub use renderer::SchemeRenderer;

/// Cells around a point whose samples a scheme's value combines: the
/// square of spacing 2 around it in its plane, and the planes below and above.
pub const REACH: usize = 2;

/// One of the hand-written plane-stack schemes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Scheme {
    /// Section 3.1: bilinear in the nearest plane of the stack.
    Bilinear,
    /// Section 3.2: bilinear in the two planes around the point, then linear between them.
    BilinearSpatial,
}

/// The schemes, in `boxforge list` order.
pub const ALL: [Scheme; 2] = [Scheme::Bilinear, Scheme::BilinearSpatial];

impl Scheme {
    /// The `--filter` name.
    pub fn parse(name: &str) -> Option<Scheme> {
        ALL.into_iter().find(|s| s.name() == name)
    }

    /// The `--filter` name (also the reference's WGSL function).
    pub fn name(self) -> &'static str {
        match self {
            Scheme::Bilinear => "mattausch_bilinear",
            Scheme::BilinearSpatial => "mattausch_bilinear_spatial",
        }
    }

    /// One line for `boxforge list`.
    pub fn description(self) -> &'static str {
        match self {
            Scheme::Bilinear => "hand-written: Mattausch et al. 2003, 3.1, bilinear in the nearest plane of the stack most perpendicular to the view (render --mode dvr only)",
            Scheme::BilinearSpatial => "hand-written: Mattausch et al. 2003, 3.2, bilinear in two planes of the view's stack, linear between them (render --mode dvr only)",
        }
    }

    /// The prefix of the adapter's and the DVR template's WGSL names.
    fn prefix(self) -> String {
        format!("{}_view", self.name())
    }
}

/// The stack for a view direction: the axis of its largest component (ties
/// to the lower axis), as [`boxforge::spec::Filter::view_variant`] picks
/// the reference axis of view-dependent box splines.
pub fn stack_for_view(view: [f64; 3]) -> usize {
    (0..3).fold(0, |best, a| if view[a].abs() > view[best].abs() { a } else { best })
}

/// The render log's line for the choice.
pub fn choice_line(scheme: Scheme, view: [f64; 3], axis: usize) -> String {
    format!(
        "{}: view ({:.2}, {:.2}, {:.2}): plane stack along {} (planes {} = m, the most perpendicular to the view)",
        scheme.name(),
        view[0],
        view[1],
        view[2],
        ["x", "y", "z"][axis],
        ["x", "y", "z"][axis]
    )
}

/// `bcc_linear`, whose module the schemes are written on.
pub fn base() -> Result<Derivation, RenderError> {
    let f = boxforge::spec::catalog::get("bcc_linear")?;
    Ok(Derivation::new(&f)?)
}

/// The whole DVR module of `scheme` on plane stack `axis`: `base`'s emitted
/// module (embedded layout), the hand-written reference, the adapter, the
/// DVR template.
pub fn dvr_source(base: &Derivation, scheme: Scheme, axis: usize) -> Result<String, RenderError> {
    let p = scheme.prefix();
    let f = scheme.name();
    let adapter = format!(
        "// {p}: {f} on plane stack {axis} for the DVR template (runtime/src/render/schemes/mod.rs).
const {p}_AXIS: i32 = {axis};

fn {p}_eval(p: vec3<f32>) -> f32 {{
    return {f}(p, {p}_AXIS);
}}

/// Value (exact) and central-difference gradient (h = 1/2).
fn {p}_eval_grad(p: vec3<f32>) -> vec4<f32> {{
    let h = 0.5;
    let gx = {p}_eval(p + vec3<f32>(h, 0.0, 0.0)) - {p}_eval(p - vec3<f32>(h, 0.0, 0.0));
    let gy = {p}_eval(p + vec3<f32>(0.0, h, 0.0)) - {p}_eval(p - vec3<f32>(0.0, h, 0.0));
    let gz = {p}_eval(p + vec3<f32>(0.0, 0.0, h)) - {p}_eval(p - vec3<f32>(0.0, 0.0, h));
    return vec4<f32>({p}_eval(p), vec3<f32>(gx, gy, gz) / (2.0 * h));
}}
"
    );
    Ok(format!(
        "{}\n{MATTAUSCH_BILINEAR}\n{adapter}\n{}",
        filter_module(base, Layout::Embedded)?,
        dvr_template(&p, false)
    ))
}

/// The scene of `scheme` on plane stack `axis` (`base` from [`base`]).
pub fn scene<'a>(
    gpu: &'a Gpu,
    base: &'a Derivation,
    vol: &'a LatticeVolume,
    scheme: Scheme,
    axis: usize,
    block: i32,
) -> Result<DvrScene<'a>, RenderError> {
    if vol.lattice != base.filter.lattice {
        return Err(RenderError::SchemeLattice { scheme: scheme.name(), lattice: vol.lattice.name.clone() });
    }
    let source = dvr_source(base, scheme, axis)?;
    let name = scheme.prefix();
    let custom = Custom { name: &name, source: &source, minmax: &base.filter.name, reach: REACH };
    DvrScene::with_source(gpu, base, vol, Layout::Embedded, block, custom)
}

/// One DVR image of `scheme`, its plane stack chosen from the view: the
/// samples uploaded, a [`SchemeRenderer`] built for `o`'s look, its timed
/// frames; the frame and the render log's line for the choice.
pub fn render(
    gpu: &Gpu,
    vol: &LatticeVolume,
    scheme: Scheme,
    tf: &TransferFunction,
    o: &DvrOptions,
) -> Result<(Frame, String), RenderError> {
    let view = crate::render::iso::view_direction(o.azimuth, o.elevation);
    let axis = stack_for_view(view);
    let volume = DeviceVolume::new(gpu, vol, Layout::Embedded)?;
    let mut renderer = SchemeRenderer::with_first_stack(gpu, &volume, scheme, tf, look_of(o), axis)?;
    let frame = renderer.timed_frames(o)?;
    Ok((frame, choice_line(scheme, view, axis)))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_stack_is_the_views_largest_axis() {
        assert_eq!(stack_for_view([0.1, -0.2, 0.9]), 2);
        assert_eq!(stack_for_view([-0.8, 0.5, 0.1]), 0);
        assert_eq!(stack_for_view([0.3, -0.6, 0.5]), 1);
        // The CLI's default view (azimuth 30, elevation 25) looks mostly along x.
        assert_eq!(stack_for_view(crate::render::iso::view_direction(30.0, 25.0)), 0);
        assert_eq!(stack_for_view(crate::render::iso::view_direction(0.0, 80.0)), 2);
        assert!(choice_line(Scheme::BilinearSpatial, [0.0, 0.0, -1.0], 2).contains("plane stack along z"));
    }

    #[test]
    fn names_round_trip_and_modules_validate_for_every_stack() {
        let base = base().unwrap();
        for s in ALL {
            assert_eq!(Scheme::parse(s.name()), Some(s));
            for axis in 0..3 {
                let src = dvr_source(&base, s, axis).unwrap();
                crate::gpu::naga_check(&src, s.name()).unwrap_or_else(|e| panic!("{} axis {axis}: {e}", s.name()));
            }
        }
        assert_eq!(Scheme::parse("bcc_linear"), None);
    }
}
