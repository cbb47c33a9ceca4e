//! Writes a Cartesian volume as an OME-Zarr pyramid of lattice samples
//! (`boxforge convert --lattice bcc|fcc [--prefilter FILTER]`), in the
//! coset layout of `cosets.rs`, streaming.
//!
//! Level k is the Cartesian level k of the pyramid [`write_pyramid`] makes
//! (same reduction), resampled on the lattice at a matched sample count
//! ([`Resampled`], what `render --resample` does in memory) and, with a
//! prefilter, convolved with it ([`Prefiltered`]), so the stored samples
//! are the filter's spline coefficients and a renderer draws them as they
//! are. The Cartesian pyramid is written first, as float32 (no rounding
//! between the passes), into a hidden folder of the output that is removed
//! at the end; each lattice chunk then reads only its footprint from it.
//! Host memory stays at a few write units and the readers' chunk caches.

use super::cosets::LatticeLayout;
use super::plan::StorePlan;
use super::write::{check_options, space_axis, write_pyramid};
use super::{OmeZarr, PyramidOptions, PyramidReport, Reduction, Selection, ZarrError, ZarrType, ZarrVolume};
use crate::volume::{BrickSource, Prefiltered, Resampled, VolumeError};
use boxforge::derive::Derivation;
use boxforge::spec::lattice::Lattice;
use std::path::Path;
use std::sync::Arc;
use zarrs::filesystem::FilesystemStore;

/// The folder inside the output that holds the Cartesian pyramid while
/// the lattice levels are made from it.
const CARTESIAN_PASS: &str = ".boxforge-cartesian";

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
    let temp = out.join(CARTESIAN_PASS);
    let cartesian = PyramidOptions { ty: ZarrType::F32, ..o.clone() };
    write_pyramid(source, &temp, &cartesian, &|done, total| progress(done, 2 * total))?;
    let image = OmeZarr::open(&temp)?;
    let cc = Lattice::builtin("cc").map_err(|e| ZarrError::Write { path: out.to_path_buf(), reason: e.to_string() })?;
    plan.create()?;
    let levels = plan.cartesian_levels().len();
    let total: u64 = (0..levels).map(|k| plan.unit_boxes(k).count() as u64).sum();
    let mut done = 0u64;
    for k in 0..levels {
        let level = ZarrVolume::new(&image, Selection { level: k, ..Selection::default() }, &cc)?;
        let resampled;
        let on_lattice: &dyn BrickSource = if l.lattice.det() == 1 {
            &level
        } else {
            resampled = Resampled::new(&level, l.lattice)?;
            &resampled
        };
        let prefiltered;
        let samples: &dyn BrickSource = match l.prefilter {
            Some(d) => {
                prefiltered = Prefiltered::new(on_lattice, d)?;
                &prefiltered
            }
            None => on_lattice,
        };
        for lo in plan.unit_boxes(k) {
            plan.write_unit(k, samples, lo)?;
            done += 1;
            progress(total + done, 2 * total);
        }
    }
    let report = plan.finish()?;
    drop(image);
    std::fs::remove_dir_all(&temp).map_err(|e| ZarrError::Write { path: out.to_path_buf(), reason: e.to_string() })?;
    Ok(report)
}

/// The group's `zarr.json`: OME-Zarr 0.5 multiscales over (c, z, y, x)
/// (or (z, y, x) for one coset) with each level's coset-grid scale and the
/// position of lattice point 0, and the `boxforge` layout attribute.
pub(super) fn write_lattice_group(
    store: &Arc<FilesystemStore>,
    layout: &LatticeLayout,
    matched: &[([usize; 3], f64)],
    channels: Option<usize>,
    o: &PyramidOptions,
) -> Result<(), Box<dyn std::error::Error>> {
    let s0 = [o.spacing[2], o.spacing[1], o.spacing[0]];
    let p = [layout.period[2], layout.period[1], layout.period[0]];
    let lead: Vec<f64> = channels.map(|_| 1.0).into_iter().collect();
    let datasets: Vec<serde_json::Value> = matched
        .iter()
        .enumerate()
        .map(|(k, &(_, lattice_scale))| {
            let f = (1u64 << k) as f64;
            let scale: Vec<f64> = (0..3).map(|a| p[a] as f64 * lattice_scale * f * s0[a]).collect();
            let scale = [lead.clone(), scale].concat();
            let mut transforms = vec![serde_json::json!({"type": "scale", "scale": scale})];
            if o.reduction == Reduction::Box && k > 0 {
                let shift: Vec<f64> = s0.iter().map(|s| s * (f - 1.0) / 2.0).collect();
                let shift = [lead.iter().map(|_| 0.0).collect(), shift].concat();
                transforms.push(serde_json::json!({"type": "translation", "translation": shift}));
            }
            serde_json::json!({"path": k.to_string(), "coordinateTransformations": transforms})
        })
        .collect();
    let space = |name: &str| space_axis(name, o);
    let mut axes: Vec<serde_json::Value> =
        channels.map(|_| serde_json::json!({"name": "c", "type": "channel"})).into_iter().collect();
    axes.extend([space("z"), space("y"), space("x")]);
    let ome = serde_json::json!({
        "version": "0.5",
        "multiscales": [{
            "name": format!("boxforge {} samples", layout.lattice),
            "axes": axes,
            "datasets": datasets,
            "type": o.reduction.name(),
            "metadata": {"method": "boxforge lattice store", "reduction": o.reduction.name()},
        }],
    });
    let scales: Vec<f64> = matched.iter().map(|m| m.1).collect();
    let mut group = zarrs::group::GroupBuilder::new().build(store.clone(), "/")?;
    group.attributes_mut().insert("ome".into(), ome);
    group.attributes_mut().insert("boxforge".into(), layout.to_json(&scales));
    group.store_metadata()?;
    Ok(())
}
