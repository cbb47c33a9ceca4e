//! `boxforge._boxforge`, the extension module under `import boxforge`
//! (python/boxforge/): thin bindings over the generator and the runtime,
//! the same code as the CLI, never a second implementation. Arrays cross
//! as NumPy float32 in (z, y, x) order, C-contiguous (x fastest, the
//! runtime's layout), and are checked with a `ValueError` naming the
//! problem; long work runs with the GIL released.
//!
//! `spec.rs`: specs (catalog names, spec files, TOML text) to reports and
//! shaders; `volume.rs`: resampling and prefiltering of a volume or of a
//! chunk with its halo; `spline.rs`: the exact evaluator at many points;
//! `store.rs`: OME-Zarr stores read and written; `render.rs`: an isosurface
//! or a volume rendering through the runtime's ray casters, in core or out
//! of core; `bounds.rs`: per-brick bounds of a spline by the runtime's pass.

use pyo3::prelude::*;

mod bounds;
mod render;
mod spec;
mod spline;
mod store;
mod volume;

#[pymodule]
fn _boxforge(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    m.add_function(wrap_pyfunction!(spec::report_json, m)?)?;
    m.add_function(wrap_pyfunction!(spec::shader, m)?)?;
    m.add_function(wrap_pyfunction!(spec::lattice_of, m)?)?;
    m.add_function(wrap_pyfunction!(volume::matched_lattice, m)?)?;
    m.add_function(wrap_pyfunction!(volume::resample, m)?)?;
    m.add_function(wrap_pyfunction!(volume::prefilter, m)?)?;
    m.add_function(wrap_pyfunction!(volume::prefilter_reach, m)?)?;
    m.add_function(wrap_pyfunction!(spline::spline_eval, m)?)?;
    m.add_function(wrap_pyfunction!(render::render_frame, m)?)?;
    m.add_function(wrap_pyfunction!(bounds::bounds, m)?)?;
    m.add_function(wrap_pyfunction!(store::open_level, m)?)?;
    m.add_function(wrap_pyfunction!(store::write_store, m)?)?;
    m.add_function(wrap_pyfunction!(volume::reduce, m)?)?;
    m.add_class::<store::PyStorePlan>()?;
    Ok(())
}
