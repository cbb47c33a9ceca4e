//! An isosurface image from Python through the runtime's ray caster
//! (`render::iso::render`, what `boxforge render --iso` draws in core), on
//! a device opened once per process (lavapipe, or any GPU wgpu finds).

use boxforge::emit::Layout;
use boxforge_runtime::gpu::Gpu;
use boxforge_runtime::render::iso::{render, RenderOptions};
use boxforge_runtime::scene::{from_cartesian, Conversion};
use boxforge_runtime::volume::{LatticeVolume, Volume};
use numpy::ndarray::Array3;
use numpy::{IntoPyArray, PyArray3, PyReadonlyArray3, PyUntypedArrayMethods};
use pyo3::exceptions::{PyRuntimeError, PyValueError};
use pyo3::prelude::*;
use std::collections::HashMap;
use std::sync::{Arc, Mutex, OnceLock};

/// The device for an adapter name (None: wgpu's choice), opened once.
fn gpu(adapter: Option<&str>) -> PyResult<Arc<Gpu>> {
    static OPENED: OnceLock<Mutex<HashMap<Option<String>, Arc<Gpu>>>> = OnceLock::new();
    let mut map = OPENED.get_or_init(Default::default).lock().expect("the device map is not poisoned");
    let key = adapter.map(str::to_string);
    if let Some(g) = map.get(&key) {
        return Ok(g.clone());
    }
    let g = Arc::new(Gpu::new(adapter).map_err(|e| PyRuntimeError::new_err(e.to_string()))?);
    map.insert(key, g.clone());
    Ok(g)
}

/// The isosurface at `iso` of `samples` (z, y, x) with the filter `spec`,
/// as an (size, size, 4) RGBA image (rows from the top). `samples` are
/// the filter's lattice samples in the embedded layout (`conversion`
/// "lattice"), or Cartesian samples taken as their lattice subset
/// ("subset", the CLI's default) or resampled at a matched count ("resample").
#[pyfunction]
#[pyo3(signature = (samples, spec, iso, conversion = "subset", size = 512, azimuth = 30.0, elevation = 25.0,
                    perspective = false, layout = "embedded", adapter = None))]
#[allow(clippy::too_many_arguments)]
pub(crate) fn render_iso<'py>(
    py: Python<'py>,
    samples: PyReadonlyArray3<'py, f32>,
    spec: &str,
    iso: f32,
    conversion: &str,
    size: u32,
    azimuth: f32,
    elevation: f32,
    perspective: bool,
    layout: &str,
    adapter: Option<&str>,
) -> PyResult<Bound<'py, PyArray3<u8>>> {
    let d = crate::spec::derivation_of(py, spec)?;
    if d.facts.dim != 3 {
        return Err(PyValueError::new_err(format!("{} is {}D: render draws 3D filters", d.filter.name, d.facts.dim)));
    }
    let layout = Layout::parse(layout).ok_or_else(|| {
        PyValueError::new_err(format!("layout {layout:?}: use embedded, packed, bricked or bricked-packed"))
    })?;
    if !(1..=8192).contains(&size) {
        return Err(PyValueError::new_err(format!("size {size}: give an image edge from 1 to 8192 pixels")));
    }
    if !iso.is_finite() {
        return Err(PyValueError::new_err("iso: give a finite iso-value"));
    }
    let s = samples.shape();
    let dims = [s[2], s[1], s[0]];
    let data =
        samples.as_slice().map_err(|_| PyValueError::new_err("samples: the array is not C-contiguous"))?.to_vec();
    let lattice = d.filter.lattice.clone();
    let volume = match conversion {
        "lattice" => LatticeVolume { lattice, dims, data },
        "subset" | "resample" => {
            let how = if conversion == "subset" { Conversion::Subset } else { Conversion::Resample };
            let vol = Volume::new(dims, data).map_err(|e| PyValueError::new_err(e.to_string()))?;
            from_cartesian(&vol, &lattice, how).map_err(|e| PyValueError::new_err(e.to_string()))?
        }
        other => return Err(PyValueError::new_err(format!("conversion {other:?}: use lattice, subset or resample"))),
    };
    let g = gpu(adapter)?;
    let o = RenderOptions {
        iso,
        width: size,
        height: size,
        azimuth,
        elevation,
        perspective,
        frames: 1,
        ..Default::default()
    };
    let frame =
        py.detach(|| render(&g, &d, &volume, layout, &o)).map_err(|e| PyRuntimeError::new_err(e.to_string()))?;
    let (w, h) = (frame.width as usize, frame.height as usize);
    Ok(Array3::from_shape_vec((h, w, 4), frame.rgba)
        .map_err(|e| PyValueError::new_err(e.to_string()))?
        .into_pyarray(py))
}
