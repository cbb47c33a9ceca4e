//! Resampling and prefiltering on NumPy arrays: a whole volume, or a chunk
//! with its halo standing for a larger volume (what a Dask task holds),
//! through the runtime's `Window`, `Resampled` and `Prefiltered`, so a
//! volume computed chunk by chunk equals the volume computed whole.

use boxforge::spec::lattice::Lattice;
use boxforge_runtime::volume::{BrickSource, Prefiltered, Resampled, Window};
use numpy::ndarray::Array3;
use numpy::{IntoPyArray, PyArray3, PyReadonlyArray3, PyUntypedArrayMethods};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;

/// (z, y, x) as Python gives it, to the runtime's (x, y, z).
fn xyz(zyx: (usize, usize, usize)) -> [usize; 3] {
    [zyx.2, zyx.1, zyx.0]
}

fn zyx(a: [usize; 3]) -> (usize, usize, usize) {
    (a[2], a[1], a[0])
}

fn value_error(e: impl std::fmt::Display) -> PyErr {
    PyValueError::new_err(e.to_string())
}

pub(crate) fn lattice_named(name: &str) -> PyResult<Lattice> {
    Lattice::builtin(name).map_err(|e| PyValueError::new_err(format!("lattice {name:?}: {e}")))
}

/// Where a box of `size` (x, y, z) sits: its origin, and the dims of the
/// volume it stands for (by default, just reaching its far corner).
fn placed(
    origin: (usize, usize, usize),
    shape: Option<(usize, usize, usize)>,
    size: [usize; 3],
) -> ([usize; 3], [usize; 3]) {
    let o = xyz(origin);
    (o, shape.map(xyz).unwrap_or(std::array::from_fn(|i| o[i] + size[i])))
}

/// The samples of a C-contiguous float32 array, with its (x, y, z) size.
fn samples<'a>(a: &'a PyReadonlyArray3<'_, f32>, what: &str) -> PyResult<(&'a [f32], [usize; 3])> {
    let s = a.shape();
    let data = a.as_slice().map_err(|_| {
        PyValueError::new_err(format!(
            "{what}: the array is not C-contiguous; pass numpy.ascontiguousarray(a, dtype=numpy.float32)"
        ))
    })?;
    let size = [s[2], s[1], s[0]];
    finite(data, size, what)?;
    Ok((data, size))
}

/// Refuses NaN and infinite samples, naming the first (a filter would
/// spread it over its whole support: garbage, not an answer).
pub(crate) fn finite(data: &[f32], size: [usize; 3], what: &str) -> PyResult<()> {
    match data.iter().position(|v| !v.is_finite()) {
        None => Ok(()),
        Some(i) => {
            let (x, y, z) = (i % size[0], (i / size[0]) % size[1], i / (size[0] * size[1]));
            Err(PyValueError::new_err(format!(
                "{what}: sample (z, y, x) = ({z}, {y}, {x}) is {}: replace NaN and infinite samples first \
                 (e.g. numpy.nan_to_num)",
                data[i]
            )))
        }
    }
}

/// The lattice box a Cartesian volume of `shape` (z, y, x) is resampled
/// on at a matched sample count, and the scale (Cartesian voxels per
/// lattice unit).
#[pyfunction]
pub(crate) fn matched_lattice(lattice: &str, shape: (usize, usize, usize)) -> PyResult<((usize, usize, usize), f64)> {
    let (dims, scale) = boxforge_runtime::volume::matched_lattice(&lattice_named(lattice)?, xyz(shape));
    Ok((zyx(dims), scale))
}

/// Samples `a` (Cartesian, at `origin` of a volume of `shape`, all z, y,
/// x) resampled on `lattice` at a matched sample count: the box
/// [`out_origin`, `out_origin + out_shape`) of the lattice volume (the
/// whole of it by default). Exact where `a` covers the box's footprint.
#[pyfunction]
#[pyo3(signature = (a, lattice, origin = (0, 0, 0), shape = None, out_origin = (0, 0, 0), out_shape = None))]
pub(crate) fn resample<'py>(
    py: Python<'py>,
    a: PyReadonlyArray3<'py, f32>,
    lattice: &str,
    origin: (usize, usize, usize),
    shape: Option<(usize, usize, usize)>,
    out_origin: (usize, usize, usize),
    out_shape: Option<(usize, usize, usize)>,
) -> PyResult<Bound<'py, PyArray3<f32>>> {
    let l = lattice_named(lattice)?;
    let cc = lattice_named("cc")?;
    let (data, size) = samples(&a, "resample")?;
    let (o, dims) = placed(origin, shape, size);
    let out = py.detach(|| -> Result<_, boxforge_runtime::volume::VolumeError> {
        let window = Window::new(data, o, size, dims, &cc)?;
        let r = Resampled::new(&window, &l)?;
        let n = out_shape.map(xyz).unwrap_or(r.dims());
        let lo = xyz(out_origin);
        if (0..3).any(|i| lo[i] + n[i] > r.dims()[i]) || n.contains(&0) {
            return Err(boxforge_runtime::volume::VolumeError::BadDims {
                dims: n,
                reason: format!("the box at {lo:?} (x, y, z) is not inside the lattice volume of {:?}", r.dims()),
            });
        }
        let mut v = vec![0f32; n.iter().product()];
        r.read_box(lo.map(|x| x as i64), n, &mut v)?;
        Ok((v, n))
    });
    let (v, n) = out.map_err(value_error)?;
    Ok(Array3::from_shape_vec((n[2], n[1], n[0]), v).map_err(value_error)?.into_pyarray(py))
}

/// Lattice samples `a` (at `origin` of a volume of `shape`, z, y, x; zero
/// off the lattice) prefiltered for the filter `spec`: the values at `a`'s
/// own box, exact where `a`'s halo covers the taps' reach
/// ([`prefilter_reach`]) or meets the volume's edge.
#[pyfunction]
#[pyo3(signature = (a, spec, origin = (0, 0, 0), shape = None))]
pub(crate) fn prefilter<'py>(
    py: Python<'py>,
    a: PyReadonlyArray3<'py, f32>,
    spec: &str,
    origin: (usize, usize, usize),
    shape: Option<(usize, usize, usize)>,
) -> PyResult<Bound<'py, PyArray3<f32>>> {
    let d = crate::spec::derivation_of(py, spec)?;
    if d.facts.dim != 3 {
        return Err(PyValueError::new_err(format!("{}: a volume is prefiltered with a 3D filter", d.filter.name)));
    }
    let (data, size) = samples(&a, "prefilter")?;
    let (o, dims) = placed(origin, shape, size);
    let v = py
        .detach(|| -> Result<_, boxforge_runtime::volume::VolumeError> {
            let window = Window::new(data, o, size, dims, &d.filter.lattice)?;
            let p = Prefiltered::new(&window, &d)?;
            let mut v = vec![0f32; size.iter().product()];
            p.read_box(o.map(|x| x as i64), size, &mut v)?;
            Ok(v)
        })
        .map_err(value_error)?;
    Ok(Array3::from_shape_vec((size[2], size[1], size[0]), v).map_err(value_error)?.into_pyarray(py))
}

/// How far the prefilter's taps reach along z, y, x: the halo a chunk needs.
#[pyfunction]
pub(crate) fn prefilter_reach(py: Python<'_>, spec: &str) -> PyResult<(usize, usize, usize)> {
    let d = crate::spec::derivation_of(py, spec)?;
    if d.facts.dim != 3 {
        return Err(PyValueError::new_err(format!("{}: a volume is prefiltered with a 3D filter", d.filter.name)));
    }
    let reach = |a: usize| d.prefilter.taps.iter().map(|(k, _)| k[a].unsigned_abs() as usize).max().unwrap_or(0);
    Ok((reach(2), reach(1), reach(0)))
}

/// The next pyramid level's box [`out_origin`, `out_origin + out_shape`)
/// (z, y, x) by `reduction` (the store writer's), from `a`: the finer
/// level's samples at `origin` of a level of `shape`, covering the box's
/// footprint (its box doubled, plus two samples each side, inside the level).
#[pyfunction]
#[pyo3(signature = (a, reduction, origin, shape, out_origin, out_shape))]
pub(crate) fn reduce<'py>(
    py: Python<'py>,
    a: PyReadonlyArray3<'py, f32>,
    reduction: &str,
    origin: (usize, usize, usize),
    shape: (usize, usize, usize),
    out_origin: (usize, usize, usize),
    out_shape: (usize, usize, usize),
) -> PyResult<Bound<'py, PyArray3<f32>>> {
    let r = crate::store::reduction_named(reduction)?;
    let (data, size) = samples(&a, "reduce")?;
    let n = xyz(out_shape);
    let v = py.detach(|| r.reduce(data, xyz(origin), size, xyz(shape), xyz(out_origin), n)).map_err(value_error)?;
    Ok(Array3::from_shape_vec((n[2], n[1], n[0]), v).map_err(value_error)?.into_pyarray(py))
}
