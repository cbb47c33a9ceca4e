//! Specs from Python: a catalog name, a spec file's path or a spec's TOML
//! text, derived once per process (a Dask worker derives each filter once,
//! not once per chunk).

use boxforge::build::report::{Report, ReportOptions};
use boxforge::derive::Derivation;
use boxforge::emit::{emit, EmitOptions, Layout};
use boxforge::spec::{self, Filter};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use std::collections::HashMap;
use std::sync::{Arc, Mutex, OnceLock};

/// The filter a spec names: TOML text (it holds a `=`), else a catalog
/// name or a spec file.
pub(crate) fn filter_of(spec: &str) -> PyResult<Filter> {
    let filter = if spec.contains('=') { Filter::from_toml(spec, "<python spec>") } else { spec::resolve(spec) };
    filter.map_err(|e| PyValueError::new_err(e.to_string()))
}

/// The derivation of a spec, remembered per process by its text.
pub(crate) fn derivation_of(py: Python<'_>, spec: &str) -> PyResult<Arc<Derivation>> {
    static DERIVED: OnceLock<Mutex<HashMap<String, Arc<Derivation>>>> = OnceLock::new();
    let map = DERIVED.get_or_init(Default::default);
    if let Some(d) = map.lock().expect("the derivation memo is not poisoned").get(spec) {
        return Ok(d.clone());
    }
    let filter = filter_of(spec)?;
    let d = py.detach(|| Derivation::new(&filter)).map_err(|e| PyValueError::new_err(e.to_string()))?;
    let d = Arc::new(d);
    map.lock().expect("the derivation memo is not poisoned").insert(spec.to_string(), d.clone());
    Ok(d)
}

/// The derivation report of a spec as JSON (what `boxforge inspect --json` prints).
#[pyfunction]
pub(crate) fn report_json(py: Python<'_>, spec: &str) -> PyResult<String> {
    let d = derivation_of(py, spec)?;
    Ok(Report::with_options(&d, &ReportOptions::default()).to_json())
}

/// The WGSL module of a spec in a layout, and its bindings as JSON.
#[pyfunction]
#[pyo3(signature = (spec, layout = "embedded"))]
pub(crate) fn shader(py: Python<'_>, spec: &str, layout: &str) -> PyResult<(String, String)> {
    let layout = Layout::parse(layout).ok_or_else(|| {
        PyValueError::new_err(format!("layout {layout:?}: use embedded, packed, bricked or bricked-packed"))
    })?;
    let d = derivation_of(py, spec)?;
    let options = EmitOptions { layout, command: "boxforge (Python)".into(), ..EmitOptions::default() };
    let module = py.detach(|| emit(&d, &options)).map_err(|e| PyValueError::new_err(e.to_string()))?;
    let bindings =
        boxforge::validate::bindings_of_wgsl(&module.source).map_err(|e| PyValueError::new_err(e.to_string()))?;
    let json = serde_json::to_string(&bindings).map_err(|e| PyValueError::new_err(e.to_string()))?;
    Ok((module.source, json))
}

/// The lattice a spec's filter is defined on (its name).
#[pyfunction]
pub(crate) fn lattice_of(spec: &str) -> PyResult<String> {
    Ok(filter_of(spec)?.lattice.name)
}
