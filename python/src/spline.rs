//! A spline evaluated on the CPU at many points: the generator's f64
//! evaluator (`Derivation::eval_f64`, the path the shaders take: locate the
//! cell, map to the reference piece, fetch, evaluate), the samples fetched
//! clamped into their box as the embedded layout's shaders fetch them; the
//! points split over every core, with the GIL released.

use numpy::ndarray::{Array1, Array2, Array3};
use numpy::{IntoPyArray, PyArray1, PyArray2, PyArray3, PyReadonlyArray2, PyReadonlyArray3, PyUntypedArrayMethods};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;

/// Value, gradient and Hessian of the spline of `spec` with `samples`
/// (z, y, x; the embedded layout) at `points` (N x 3, z, y, x in sample
/// units); derivatives along (z, y, x). `order` 0: values only; 1: and
/// gradients; 2: and Hessians (the others come back empty).
#[pyfunction]
#[allow(clippy::type_complexity)]
pub(crate) fn spline_eval<'py>(
    py: Python<'py>,
    spec: &str,
    points: PyReadonlyArray2<'py, f64>,
    samples: PyReadonlyArray3<'py, f32>,
    order: usize,
) -> PyResult<(Bound<'py, PyArray1<f64>>, Bound<'py, PyArray2<f64>>, Bound<'py, PyArray3<f64>>)> {
    let d = crate::spec::derivation_of(py, spec)?;
    if d.facts.dim != 3 {
        return Err(PyValueError::new_err(format!(
            "{} is {}D: Spline evaluates 3D filters on 3D samples",
            d.filter.name, d.facts.dim
        )));
    }
    let p = points.shape();
    if p.len() != 2 || p[1] != 3 {
        return Err(PyValueError::new_err(format!("points: expected an N x 3 array (z, y, x), got shape {p:?}")));
    }
    let pts = points.as_slice().map_err(|_| PyValueError::new_err("points: the array is not C-contiguous"))?;
    if let Some(i) = pts.iter().position(|v| !v.is_finite()) {
        return Err(PyValueError::new_err(format!("points: row {} has a NaN or infinite coordinate", i / 3)));
    }
    let s = samples.shape();
    let n = [s[2], s[1], s[0]];
    let data = samples.as_slice().map_err(|_| PyValueError::new_err("samples: the array is not C-contiguous"))?;
    let rows: Vec<[f64; 3]> = pts.chunks(3).map(|r| [r[2], r[1], r[0]]).collect();
    let results = py.detach(|| {
        let fetch = |j: &[i64]| {
            let c = |a: usize| j[a].clamp(0, n[a] as i64 - 1) as usize;
            f64::from(data[c(0) + n[0] * (c(1) + n[1] * c(2))])
        };
        boxforge_runtime::par::par_map(&rows, |x| match order {
            0 => (d.eval_f64(x, &fetch).0, vec![], vec![]),
            1 => {
                let (v, g) = d.eval_f64(x, &fetch);
                (v, g, vec![])
            }
            _ => d.eval_f64_hessian(x, &fetch),
        })
    });
    let count = rows.len();
    let values = Array1::from_iter(results.iter().map(|r| r.0));
    // (x, y, z) derivatives back to (z, y, x).
    let (gn, hn) = (if order >= 1 { count } else { 0 }, if order >= 2 { count } else { 0 });
    let grads = Array2::from_shape_fn((gn, 3), |(i, a)| results[i].1[2 - a]);
    let hessians = Array3::from_shape_fn((hn, 3, 3), |(i, a, b)| results[i].2[(2 - a) * 3 + (2 - b)]);
    Ok((values.into_pyarray(py), grads.into_pyarray(py), hessians.into_pyarray(py)))
}
