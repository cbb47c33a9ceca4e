//! The work of a checked 3D `render`: the filter derived (its view variant
//! first), the transfer function loaded, then out of core (paged.rs) or the
//! volume loaded and one frame drawn in core, written to PNG with a line
//! of statistics.

use super::checked::{DvrLook, Look, ThreeRequest};
use super::look::{default_ramp, dvr_options, named_tf};
use super::{dvr, paged};
use crate::common::Failure;
use crate::request;
use boxforge::derive::Derivation;
use boxforge_runtime::gpu::Gpu;
use boxforge_runtime::render::dvr::transfer::TransferFunction;
use boxforge_runtime::render::dvr::DvrOptions;
use boxforge_runtime::render::iso::{self as render, RenderOptions};
use boxforge_runtime::scene::{self, Conversion};
use boxforge_runtime::volume::{BrickShape, SampleFormat, VolumeOptions};

pub fn run(r: &ThreeRequest) -> Result<(), Failure> {
    let f = &r.frame;
    let variant;
    let filter = if r.filter.view_dependent {
        // The variant for this frame's view (Mattausch et al.: shear
        // planes and shear direction follow the view direction).
        let (f_view, choice) = r.filter.view_variant(render::view_direction(f.azimuth, f.elevation))?;
        eprintln!("{choice}");
        variant = f_view;
        &variant
    } else {
        &r.filter
    };
    let d = Derivation::new(filter)?;
    request::check_shade_degree(&d, &r.shade)?;
    if r.shade.mode.needs_hessian() && d.facts.continuity < 2 {
        eprintln!(
            "warning: {} is C^{}: its Hessian jumps across knot planes, so curvature is discontinuous there (C^2 filters such as bcc7 or cc_tricubic give smooth curvature)",
            d.filter.name,
            d.facts.continuity,
        );
    }
    let tf = match &r.look {
        Look::Dvr(look) => named_tf(&look.tf)?,
        Look::Iso(_) => None,
    };
    if let Some(p) = &r.paged {
        return paged::run(r, p, &d, tf);
    }
    in_core(r, &d, tf)
}

/// What the frame draws once the data is loaded.
enum Drawn<'a> {
    Iso(boxforge_runtime::render::iso::HitMode),
    /// With `--tf`, or the default ramp over the data.
    Dvr(&'a DvrLook, TransferFunction),
}

/// Loads the volume, draws one frame with the renderer the request chose
/// and writes it.
fn in_core(r: &ThreeRequest, d: &Derivation, tf: Option<TransferFunction>) -> Result<(), Failure> {
    let (f, lat) = (&r.frame, &r.filter.lattice);
    let conversion = if r.source.resample { Conversion::Resample } else { Conversion::Subset };
    let vol = match r.source.zarr {
        Some(s) => scene::load_zarr(std::path::Path::new(&r.source.volume), s, lat, conversion),
        None => scene::load(&r.source.volume, r.source.raw.as_deref(), lat, conversion),
    }
    .map_err(|e| Failure(e.to_string()))?;
    let (lo, hi) = vol.data.iter().fold((f32::INFINITY, f32::NEG_INFINITY), |(a, b), &v| (a.min(v), b.max(v)));
    let drawn = match (&r.look, tf) {
        (Look::Dvr(look), tf) => Drawn::Dvr(look, tf.unwrap_or_else(|| default_ramp(lo, hi))),
        (Look::Iso(hit), _) => Drawn::Iso(*hit),
    };
    let warning = match &drawn {
        Drawn::Dvr(_, tf) => request::tf_warning(&tf.table(), lo, hi),
        Drawn::Iso(_) => request::iso_warning(f.iso, lo, hi),
    };
    if let Some(w) = warning {
        eprintln!("{w}");
    }
    let format = r.format;
    let volume = VolumeOptions {
        format,
        bricks: BrickShape {
            edge: r.brick.unwrap_or(BrickShape::DEFAULT_EDGE),
            halo: boxforge::emit::bricks::brick_halo(d),
        },
        max_pool_edge: None,
    };
    format.check_values(&vol.data).map_err(|e| Failure(e.to_string()))?;
    if format != SampleFormat::F32 {
        let (slo, shi) = vol.sample_range();
        eprintln!(
            "samples stored as {}: {} bytes each, at most {:.3e} from the data (half a level over [{slo}, {shi}])",
            format.name(),
            format.bytes(),
            format.max_error(slo, shi)
        );
    }
    let gpu = Gpu::new(f.adapter.as_deref()).map_err(|e| Failure(e.to_string()))?;
    request::check_image_limits(f.size, &gpu.limits())?;
    let shown = r.scheme.map_or(d.filter.name.as_str(), |s| s.name());
    eprintln!("rendering {} ({} samples) with {shown} on {} ...", r.source.volume, vol.samples(), gpu.describe());
    let frame = match &drawn {
        Drawn::Dvr(look, tf) => {
            let o = DvrOptions { progress: true, frames: 1, volume, curvature: look.curvature, ..dvr_options(r, look) };
            dvr::frame(&gpu, d, &vol, r.layout, tf, &o, look.how)
        }
        Drawn::Iso(hit) => {
            let opts = RenderOptions {
                iso: f.iso,
                width: f.size,
                height: f.size,
                azimuth: f.azimuth,
                elevation: f.elevation,
                perspective: f.perspective,
                skip: r.skip,
                skip_map: r.skip_map,
                step: f.step,
                hit: *hit,
                progress: true,
                frames: 1,
                volume,
                shade: r.shade,
                ..RenderOptions::default()
            };
            render::render(&gpu, d, &vol, r.layout, &opts).map_err(|e| e.to_string())
        }
    }
    .map_err(|e| Failure(request::volume_over_limits(&vol, r.layout, &gpu.limits()).unwrap_or(e)))?;
    let out = &f.out;
    render::write_png(out, frame.width, frame.height, &frame.rgba)
        .map_err(|e| Failure(format!("cannot write {}: {e}", out.display())))?;
    let map = frame.skip_map.filter(|_| r.skip).map_or(String::new(), |m| {
        format!(
            "; skip map {:.2} ms, {} KiB, mean skip distance {:.1} blocks{}",
            m.build_ms,
            m.bytes.div_ceil(1024),
            m.mean_distance,
            if r.skip_map == boxforge_runtime::render::blocks::SkipMap::OneBlock {
                " (clamped to one block)"
            } else {
                ""
            }
        )
    });
    let (what, empty) = match drawn {
        Drawn::Dvr(..) => ("volume rendering ", "transparent under the transfer function"),
        Drawn::Iso(_) => ("", "empty"),
    };
    outln!(
        "{}: {}x{} {what}in {:.1} ms per frame ({:.0}% of blocks {empty}{map})",
        out.display(),
        f.size,
        f.size,
        frame.ms_per_frame,
        frame.empty_blocks * 100.0
    );
    Ok(())
}
