//! OME-Zarr stores from Python: a level read whole (a Cartesian image, or
//! a store of lattice samples as its lattice volume), and a volume written
//! as a pyramid, of Cartesian or lattice samples, by the CLI's writers.

use crate::volume::lattice_named;
use boxforge_runtime::volume::zarr::{
    write_lattice_pyramid, write_pyramid, LatticeOptions, OmeZarr, PyramidOptions, Reduction, Selection, StorePlan,
    ZarrType, ZarrVolume,
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
    let reduction = reduction_named(reduction)?;
    let derivation = prefilter.map(|p| crate::spec::derivation_of(py, p)).transpose()?;
    let lattice = match (lattice, &derivation) {
        (Some(name), _) => Some(lattice_named(name)?),
        (None, Some(d)) => Some(d.filter.lattice.clone()),
        (None, None) => None,
    };
    let ty = type_named(dtype)?;
    let s = a.shape();
    let data = a.as_slice().map_err(|_| PyValueError::new_err("to_ome_zarr: the array is not C-contiguous"))?.to_vec();
    crate::volume::finite(&data, [s[2], s[1], s[0]], "to_ome_zarr")?;
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

pub(crate) fn reduction_named(name: &str) -> PyResult<Reduction> {
    Ok(match name {
        "box" => Reduction::Box,
        "subsample" => Reduction::Subsample,
        "tent" => Reduction::Tent,
        "binomial" => Reduction::Binomial,
        other => {
            return Err(PyValueError::new_err(format!("reduction {other:?}: use box, subsample, tent or binomial")))
        }
    })
}

fn type_named(dtype: Option<&str>) -> PyResult<ZarrType> {
    Ok(match dtype {
        None | Some("float32") => ZarrType::F32,
        Some("uint8") => ZarrType::U8,
        Some("uint16") => ZarrType::U16,
        Some("int16") => ZarrType::I16,
        Some(other) => {
            return Err(PyValueError::new_err(format!("dtype {other:?}: use float32, uint8, uint16 or int16")))
        }
    })
}

/// The arguments a plan is made from, kept so that it pickles as them.
type PlanArgs = (
    String,
    (usize, usize, usize),
    Option<String>,
    Option<String>,
    usize,
    Option<usize>,
    Option<usize>,
    String,
    Option<String>,
    (f64, f64, f64),
    Option<String>,
);

/// A store `boxforge convert` would write, planned and written unit by
/// unit by any number of processes (the runtime's `StorePlan`): what
/// `boxforge.dask.to_ome_zarr` ships to its workers. Shapes are (z, y, x).
#[pyclass(name = "StorePlan", module = "boxforge._boxforge", frozen)]
pub(crate) struct PyStorePlan {
    plan: StorePlan,
    args: PlanArgs,
}

impl PyStorePlan {
    /// The plan of the Cartesian pyramid the store is made from: its pass, or itself.
    fn cartesian(&self) -> PyResult<StorePlan> {
        Ok(self.plan.cartesian_pass().unwrap_or_else(|| self.plan.clone()))
    }
}

/// The low corner of write unit `i` of level `level` (z slowest).
fn nth_unit(plan: &StorePlan, level: usize, i: usize) -> PyResult<[usize; 3]> {
    if level >= plan.cartesian_levels().len() {
        return Err(PyValueError::new_err(format!("level {level}: the store has {} levels", plan.levels().len())));
    }
    plan.unit_boxes(level).nth(i).ok_or_else(|| {
        PyValueError::new_err(format!("unit {i}: level {level} has {} units", plan.unit_boxes(level).count()))
    })
}

#[pymethods]
impl PyStorePlan {
    #[new]
    #[pyo3(signature = (path, shape, lattice = None, prefilter = None, chunk = 64, shard = None, levels = None,
                        reduction = "box".to_string(), dtype = None, spacing = (1.0, 1.0, 1.0), unit = None))]
    #[allow(clippy::too_many_arguments)]
    fn new(
        path: String,
        shape: (usize, usize, usize),
        lattice: Option<String>,
        prefilter: Option<String>,
        chunk: usize,
        shard: Option<usize>,
        levels: Option<usize>,
        reduction: String,
        dtype: Option<String>,
        spacing: (f64, f64, f64),
        unit: Option<String>,
    ) -> PyResult<Self> {
        let filter = prefilter.as_deref().map(crate::spec::filter_of).transpose()?;
        let lattice_of_store = match (&lattice, &filter) {
            (Some(name), _) => Some(lattice_named(name)?),
            (None, Some(f)) => Some(f.lattice.clone()),
            (None, None) => None,
        };
        if let (Some(f), Some(l)) = (&filter, &lattice_of_store) {
            if f.lattice.name != l.name {
                return Err(value_error(boxforge_runtime::volume::VolumeError::LatticeMismatch {
                    filter: f.name.clone(),
                    filter_lattice: f.lattice.name.clone(),
                    data_lattice: l.name.clone(),
                }));
            }
        }
        let options = PyramidOptions {
            chunk,
            shard,
            levels,
            reduction: reduction_named(&reduction)?,
            ty: type_named(dtype.as_deref())?,
            spacing: [spacing.2, spacing.1, spacing.0],
            unit: unit.clone(),
            ..PyramidOptions::default()
        };
        let with_lattice = lattice_of_store.as_ref().map(|l| (l, filter.as_ref().map(|f| f.name.clone())));
        let plan = StorePlan::new(Path::new(&path), [shape.2, shape.1, shape.0], &options, with_lattice)
            .map_err(value_error)?;
        let args = (path, shape, lattice, prefilter, chunk, shard, levels, reduction, dtype, spacing, unit);
        Ok(PyStorePlan { plan, args })
    }

    /// Pickles as the arguments it was made from.
    fn __getnewargs__(&self) -> PlanArgs {
        self.args.clone()
    }

    /// The Cartesian levels (z, y, x) each stored level is made from, finest first.
    #[getter]
    fn cartesian_levels(&self) -> Vec<(usize, usize, usize)> {
        self.plan.cartesian_levels().iter().map(|d| (d[2], d[1], d[0])).collect()
    }

    /// The samples each level stores (z, y, x): the Cartesian levels, or their lattice boxes.
    #[getter]
    fn levels(&self) -> Vec<(usize, usize, usize)> {
        self.plan.levels().iter().map(|d| (d[2], d[1], d[0])).collect()
    }

    /// The lattice of the stored samples (None: a Cartesian store).
    #[getter]
    fn lattice(&self) -> Option<String> {
        self.plan.lattice().map(|l| l.name.clone())
    }

    /// The edge (z, y, x) of the samples box one write unit holds: blocks
    /// of this shape (smaller at the far edges) are written whole by one writer.
    #[getter]
    fn block(&self) -> (usize, usize, usize) {
        let (p, u) = (self.plan.period(), self.plan.unit());
        (p[2] * u, p[1] * u, p[0] * u)
    }

    /// The reduction between Cartesian levels.
    #[getter]
    fn reduction(&self) -> &'static str {
        self.plan.reduction().name()
    }

    /// Writes level `level`'s block at `origin` (z, y, x): one write unit's
    /// samples box, whole (see `block`).
    fn write(
        &self,
        py: Python<'_>,
        level: usize,
        block: PyReadonlyArray3<'_, f32>,
        origin: (usize, usize, usize),
    ) -> PyResult<()> {
        let s = block.shape();
        let size = [s[2], s[1], s[0]];
        let data = block.as_slice().map_err(|_| PyValueError::new_err("write: the block is not C-contiguous"))?;
        crate::volume::finite(data, size, "to_ome_zarr")?;
        py.detach(|| self.plan.write_block(level, data, [origin.2, origin.1, origin.0], size)).map_err(value_error)
    }

    /// The write units of Cartesian level `level` (`cartesian=True`: of the
    /// Cartesian pyramid the store is made from, a lattice store's hidden
    /// pass) or of the stored level: how many there are.
    #[pyo3(signature = (level, cartesian = false))]
    fn unit_count(&self, level: usize, cartesian: bool) -> PyResult<usize> {
        let plan = if cartesian { self.cartesian()? } else { self.plan.clone() };
        if level >= plan.cartesian_levels().len() {
            return Err(PyValueError::new_err(format!("level {level}: the store has {} levels", plan.levels().len())));
        }
        Ok(plan.unit_boxes(level).count())
    }

    /// The edge (z, y, x) of the Cartesian block one write unit of the
    /// Cartesian pyramid holds (level 0 is written in such blocks).
    #[getter]
    fn cartesian_block(&self) -> (usize, usize, usize) {
        let u = self.plan.unit();
        (u, u, u)
    }

    /// Makes the output folder (it must not exist, or be empty), the levels'
    /// arrays and, for a lattice store, its Cartesian pass's.
    fn create(&self, py: Python<'_>) -> PyResult<()> {
        py.detach(|| {
            self.plan.make_folder()?;
            self.plan.create()?;
            if let Some(pass) = self.plan.cartesian_pass() {
                pass.make_folder()?;
                pass.create()?;
            }
            Ok::<(), boxforge_runtime::volume::VolumeError>(())
        })
        .map_err(value_error)
    }

    /// Writes Cartesian level 0's block at `origin` (z, y, x; a write unit
    /// of the Cartesian pyramid, whole, see `cartesian_block`).
    fn write_cartesian(
        &self,
        py: Python<'_>,
        block: PyReadonlyArray3<'_, f32>,
        origin: (usize, usize, usize),
    ) -> PyResult<()> {
        let plan = self.cartesian()?;
        let s = block.shape();
        let size = [s[2], s[1], s[0]];
        let data = block.as_slice().map_err(|_| PyValueError::new_err("write: the block is not C-contiguous"))?;
        crate::volume::finite(data, size, "to_ome_zarr")?;
        py.detach(|| plan.write_block(0, data, [origin.2, origin.1, origin.0], size)).map_err(value_error)
    }

    /// Writes unit `unit` of Cartesian level `level` >= 1, reduced from the
    /// level before it as stored (every unit of that level written first).
    fn write_reduced(&self, py: Python<'_>, level: usize, unit: usize) -> PyResult<()> {
        let plan = self.cartesian()?;
        let lo = nth_unit(&plan, level, unit)?;
        py.detach(|| plan.write_reduced_unit(level, lo)).map_err(value_error)
    }

    /// Writes the Cartesian pass's group metadata (every level written):
    /// the lattice levels can be made from it.
    fn finish_cartesian(&self, py: Python<'_>) -> PyResult<()> {
        if let Some(pass) = self.plan.cartesian_pass() {
            py.detach(|| pass.finish()).map_err(value_error)?;
        }
        Ok(())
    }

    /// Writes unit `unit` of lattice level `level` from the finished
    /// Cartesian pass: resampled, prefiltered, as cosets.
    fn write_lattice(&self, py: Python<'_>, level: usize, unit: usize) -> PyResult<()> {
        let lo = nth_unit(&self.plan, level, unit)?;
        let derivation = self.args.3.as_deref().map(|p| crate::spec::derivation_of(py, p)).transpose()?;
        py.detach(|| self.plan.write_lattice_unit(level, lo, derivation.as_deref())).map_err(value_error)
    }

    /// Writes the group's metadata: the store is complete. Returns each level's samples (z, y, x).
    fn finish(&self, py: Python<'_>) -> PyResult<Vec<(usize, usize, usize)>> {
        let report = py
            .detach(|| {
                let report = self.plan.finish()?;
                self.plan.remove_cartesian_pass()?;
                Ok::<_, boxforge_runtime::volume::VolumeError>(report)
            })
            .map_err(value_error)?;
        Ok(report.levels.iter().map(|d| (d[2], d[1], d[0])).collect())
    }
}
