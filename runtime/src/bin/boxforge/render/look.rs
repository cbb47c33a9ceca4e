//! The DVR look of a checked request: its options and its transfer
//! function, shared by the in-core (core.rs) and out-of-core (paged.rs) work.

use super::checked::{DvrLook, Frame, ThreeRequest};
use crate::common::Failure;
use crate::request::TfChoice;
use boxforge_runtime::render::dvr::transfer::TransferFunction;
use boxforge_runtime::render::dvr::DvrOptions;

/// The DVR options of the request for its frame, in core and out of core alike.
pub fn dvr_options(r: &ThreeRequest, look: &DvrLook) -> DvrOptions {
    let f: &Frame = &r.frame;
    DvrOptions {
        width: f.size,
        height: f.size,
        azimuth: f.azimuth,
        elevation: f.elevation,
        perspective: f.perspective,
        skip: r.skip,
        skip_map: r.skip_map,
        preintegrate: look.preintegrate,
        step: f.step,
        ..Default::default()
    }
}

/// `--tf`: the named transfer function, or None for the default ramp
/// (chosen once the data's range is known).
pub fn named_tf(tf: &TfChoice) -> Result<Option<TransferFunction>, Failure> {
    match tf {
        TfChoice::Named(name) => Ok(Some(TransferFunction::load(name).map_err(|e| Failure(format!("--tf {e}")))?)),
        TfChoice::Ramp => Ok(None),
    }
}

/// The default ramp over [lo, hi], announced on stderr.
pub fn default_ramp(lo: f32, hi: f32) -> TransferFunction {
    let ramp = TransferFunction::ramp(lo as f64, hi as f64);
    eprintln!("no --tf given: using the default transfer function, a {} (give --tf to choose one)", ramp.name);
    ramp
}
