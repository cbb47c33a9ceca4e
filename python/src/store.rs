//! OME-Zarr stores from Python: a level read whole (a Cartesian image, or
//! a store of lattice samples as its lattice volume), and a volume written
//! as a pyramid, of Cartesian or lattice samples, by the CLI's writers.

use crate::volume::lattice_named;
use boxforge_runtime::volume::zarr::{
    write_lattice_pyramid, write_pyramid, LatticeOptions, OmeZarr, PyramidOptions, Reduction, Selection, ZarrType,
    ZarrVolume,
};
use boxforge_runtime::volume::LatticeVolume;
use numpy::ndarray::Array3;
use numpy::{IntoPyArray, PyArray3, PyReadonlyArray3, PyUntypedArrayMethods};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use std::path::Path;

fn value_error(e: impl std::fmt::Display) -> PyErr {
    PyValueError::new_err(e.to_string())
}

/// Level `level` (channel, time point) of the store at `path` (a folder or
/// an http:// URL): the samples (z, y, x), the lattice they are on, the
/// voxel size (z, y, x) and its unit, and the prefilter they went through.
#[pyfunction]
#[pyo3(signature = (path, level = 0, channel = 0, time = 0))]
#[allow(clippy::type_complexity)]
pub(crate) fn open_level<'py>(
    py: Python<'py>,
    path: &str,
    level: usize,
    channel: usize,
    time: usize,
) -> PyResult<(Bound<'py, PyArray3<f32>>, String, (f64, f64, f64), Option<String>, Option<String>)> {
    let out = py.detach(|| -> Result<_, boxforge_runtime::volume::VolumeError> {
        let image = OmeZarr::open(Path::new(path))?;
        let s = Selection { level, channel, time };
        let (lattice, prefilter) = match image.layout() {
            Some(l) => (l.lattice.clone(), l.prefilter.clone()),
            None => ("cc".to_string(), None),
        };
        let l = boxforge::spec::lattice::Lattice::builtin(&lattice)
            .map_err(|e| boxforge_runtime::volume::VolumeError::BadDims { dims: [0; 3], reason: e.to_string() })?;
        let v = ZarrVolume::new(&image, s, &l)?;
        let (spacing, unit) = (v.spacing(), v.space_unit().map(str::to_string));
        let samples: LatticeVolume = if v.is_lattice_store() {
            v.to_lattice_volume()?
        } else {
            let c = v.to_volume()?;
            LatticeVolume { lattice: l.clone(), dims: c.dims, data: c.data }
        };
        Ok((samples, lattice, spacing, unit, prefilter))
    });
    let (v, lattice, spacing, unit, prefilter) = out.map_err(value_error)?;
    let d = v.dims;
    let array = Array3::from_shape_vec((d[2], d[1], d[0]), v.data).map_err(value_error)?.into_pyarray(py);
    Ok((array, lattice, (spacing[2], spacing[1], spacing[0]), unit, prefilter))
}

/// Writes the Cartesian volume `a` (z, y, x) at `path` as an OME-Zarr 0.5
/// pyramid: of its samples, or of lattice samples (`lattice`, `prefilter`)
/// as `boxforge convert` writes them. Returns each level's dims (z, y, x).
#[pyfunction]
#[pyo3(signature = (a, path, lattice = None, prefilter = None, chunk = 64, shard = None, levels = None,
                    reduction = "box", dtype = None, spacing = (1.0, 1.0, 1.0), unit = None))]
#[allow(clippy::too_many_arguments)]
pub(crate) fn write_store(
    py: Python<'_>,
    a: PyReadonlyArray3<'_, f32>,
    path: &str,
    lattice: Option<&str>,
    prefilter: Option<&str>,
    chunk: usize,
    shard: Option<usize>,
    levels: Option<usize>,
    reduction: &str,
    dtype: Option<&str>,
    spacing: (f64, f64, f64),
    unit: Option<String>,
) -> PyResult<Vec<(usize, usize, usize)>> {
    let reduction = match reduction {
        "box" => Reduction::Box,
        "subsample" => Reduction::Subsample,
        "tent" => Reduction::Tent,
        "binomial" => Reduction::Binomial,
        other => {
            return Err(PyValueError::new_err(format!("reduction {other:?}: use box, subsample, tent or binomial")))
        }
    };
    let derivation = prefilter.map(|p| crate::spec::derivation_of(py, p)).transpose()?;
    let lattice = match (lattice, &derivation) {
        (Some(name), _) => Some(lattice_named(name)?),
        (None, Some(d)) => Some(d.filter.lattice.clone()),
        (None, None) => None,
    };
    let ty = match dtype {
        None | Some("float32") => ZarrType::F32,
        Some("uint8") => ZarrType::U8,
        Some("uint16") => ZarrType::U16,
        Some("int16") => ZarrType::I16,
        Some(other) => {
            return Err(PyValueError::new_err(format!("dtype {other:?}: use float32, uint8, uint16 or int16")))
        }
    };
    let s = a.shape();
    let data = a.as_slice().map_err(|_| PyValueError::new_err("to_ome_zarr: the array is not C-contiguous"))?.to_vec();
    let source = LatticeVolume { lattice: lattice_named("cc")?, dims: [s[2], s[1], s[0]], data };
    let options = PyramidOptions {
        chunk,
        shard,
        levels,
        reduction,
        ty,
        spacing: [spacing.2, spacing.1, spacing.0],
        unit,
        ..PyramidOptions::default()
    };
    let out = Path::new(path);
    let report = py
        .detach(|| match &lattice {
            Some(l) => {
                let l = LatticeOptions { lattice: l, prefilter: derivation.as_deref() };
                write_lattice_pyramid(&source, out, &options, l, &|_, _| {})
            }
            None => write_pyramid(&source, out, &options, &|_, _| {}),
        })
        .map_err(value_error)?;
    Ok(report.levels.iter().map(|d| (d[2], d[1], d[0])).collect())
}
