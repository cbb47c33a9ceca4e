//! The pyramid writers of `boxforge convert`, one process writing every
//! unit of a [`StorePlan`] in turn: [`write_pyramid`] (Cartesian samples)
//! and [`write_lattice_pyramid`] (`--lattice bcc|fcc [--prefilter FILTER]`,
//! in the coset layout of `cosets.rs`), streaming.
//!
//! Level k of a lattice store is the Cartesian level k of the pyramid
//! [`write_pyramid`] makes (same reduction), resampled on the lattice at a
//! matched sample count ([`Resampled`](crate::volume::Resampled), what
//! `render --resample` does in memory) and, with a prefilter, convolved
//! with it ([`Prefiltered`](crate::volume::Prefiltered)), so the stored
//! samples are the filter's spline coefficients and a renderer draws them
//! as they are. The Cartesian pyramid is written first, as float32 (no
//! rounding between the passes), into a hidden folder of the output that
//! is removed at the end; each lattice unit then reads only its footprint
//! from it. Host memory stays at a few write units and the readers' chunk
//! caches.

use super::plan::StorePlan;
use super::write::{check_options, open_level, Reduced, StoredLevel};
use super::{OmeZarr, PyramidOptions, PyramidReport, ZarrError, ZarrType};
use crate::volume::{BrickSource, VolumeError};
use boxforge::derive::Derivation;
use boxforge::spec::lattice::Lattice;
use std::path::Path;

/// Writes the Cartesian volume `source` (its lattice must be `cc`) as an
/// OME-Zarr 0.5 image at `out`, a path that does not exist or is an empty
/// folder. `progress(done, total)` is called after each write unit.
pub fn write_pyramid(
    source: &dyn BrickSource,
    out: &Path,
    o: &PyramidOptions,
    progress: &dyn Fn(u64, u64),
) -> Result<PyramidReport, VolumeError> {
    let plan = StorePlan::new(out, source.dims(), o, None)?;
    plan.make_folder()?;
    plan.create()?;
    let dims = plan.cartesian_levels().to_vec();
    let total: u64 = (0..dims.len()).map(|k| plan.unit_boxes(k).count() as u64).sum();
    let mut done = 0u64;
    for k in 0..dims.len() {
        let reduced;
        let samples: &dyn BrickSource = if k == 0 {
            source
        } else {
            reduced = StoredLevel { out, array: open_level(out, k - 1)?, dims: dims[k - 1], o };
            &Reduced { fine: &reduced, dims: dims[k], reduction: o.reduction }
        };
        for lo in plan.unit_boxes(k) {
            plan.write_unit(k, samples, lo)?;
            done += 1;
            progress(done, total);
        }
    }
    plan.finish()
}

/// What a lattice store holds.
#[derive(Clone, Copy)]
pub struct LatticeOptions<'a> {
    /// The lattice the samples are on (`bcc`, `fcc`, a spec's lattice; `cc`
    /// keeps the grid, for a prefilter alone).
    pub lattice: &'a Lattice,
    /// The filter whose prefilter the samples go through, if any (on `lattice`).
    pub prefilter: Option<&'a Derivation>,
}

/// Writes the Cartesian volume `source` at `out` (a new or empty folder) as
/// lattice samples, each level's lattice box in [`PyramidReport::levels`].
/// `progress(done, total)` follows both passes.
pub fn write_lattice_pyramid(
    source: &dyn BrickSource,
    out: &Path,
    o: &PyramidOptions,
    l: LatticeOptions,
    progress: &dyn Fn(u64, u64),
) -> Result<PyramidReport, VolumeError> {
    check_options(o)?;
    if let Some(d) = l.prefilter {
        if d.filter.lattice.name != l.lattice.name || d.facts.dim != 3 {
            return Err(VolumeError::LatticeMismatch {
                filter: d.filter.name.clone(),
                filter_lattice: d.filter.lattice.name.clone(),
                data_lattice: l.lattice.name.clone(),
            });
        }
        if o.ty != ZarrType::F32 {
            return Err(ZarrError::CoefficientType { ty: o.ty.name() }.into());
        }
    }
    let prefilter = l.prefilter.map(|d| d.filter.name.clone());
    let plan = StorePlan::new(out, source.dims(), o, Some((l.lattice, prefilter)))?;
    plan.make_folder()?;
    let pass = plan.cartesian_pass().expect("a lattice store's plan has a Cartesian pass");
    let cartesian = PyramidOptions { ty: ZarrType::F32, ..o.clone() };
    write_pyramid(source, pass.path(), &cartesian, &|done, total| progress(done, 2 * total))?;
    plan.create()?;
    let levels = plan.cartesian_levels().len();
    let total: u64 = (0..levels).map(|k| plan.unit_boxes(k).count() as u64).sum();
    let mut done = 0u64;
    let image = OmeZarr::open(pass.path())?;
    for k in 0..levels {
        let units: Vec<[usize; 3]> = plan.unit_boxes(k).collect();
        plan.with_lattice_samples(&image, k, l.prefilter, &mut |samples| {
            for &lo in &units {
                plan.write_unit(k, samples, lo)?;
                done += 1;
                progress(total + done, 2 * total);
            }
            Ok(())
        })?;
    }
    let report = plan.finish()?;
    drop(image);
    plan.remove_cartesian_pass()?;
    Ok(report)
}
