//! Images from Python through the runtime's ray casters, the CLI's own
//! renderers: an isosurface (`render::iso::render`, what `boxforge render`
//! draws in core) or a volume rendering (`render::dvr::render`, `--mode
//! dvr`), in core or out of core within a device budget (the paged
//! renderers of `render::paged`, what `--gpu-budget` draws: bricks paged
//! into a pool as rays reach them, from an array or lazily from an
//! OME-Zarr store), on a device opened once per process (lavapipe, or any
//! GPU wgpu finds).

use boxforge::derive::Derivation;
use boxforge::emit::Layout;
use boxforge_runtime::gpu::Gpu;
use boxforge_runtime::render::blocks::SkipMap;
use boxforge_runtime::render::dvr::transfer::TransferFunction;
use boxforge_runtime::render::dvr::{DvrLook, DvrOptions};
use boxforge_runtime::render::iso::{Frame, RenderOptions};
use boxforge_runtime::render::paged::{PagedDvrRenderer, PagedIsoRenderer, PagedOptions};
use boxforge_runtime::render::RenderError;
use boxforge_runtime::scene::{from_cartesian, Conversion};
use boxforge_runtime::volume::zarr::{OmeZarr, Selection, ZarrVolume};
use boxforge_runtime::volume::{BrickShape, BrickSource, LatticeVolume, Volume, VolumeError, VolumeOptions};
use numpy::ndarray::Array3;
use numpy::{IntoPyArray, PyArray3, PyReadonlyArray3, PyUntypedArrayMethods};
use pyo3::exceptions::{PyRuntimeError, PyValueError};
use pyo3::prelude::*;
use std::collections::HashMap;
use std::sync::{Arc, Mutex, OnceLock};

/// The ray step in cells (`render --step`'s default, in core and out of core).
const STEP: f32 = 0.25;

fn value_error(e: impl std::fmt::Display) -> PyErr {
    PyValueError::new_err(e.to_string())
}

/// A renderer's error as Python sees it: the device failing is a
/// `RuntimeError`; everything the arguments decide (a budget below what the
/// renderer estimates it needs, a volume past the adapter's limits, a
/// brick edge the lattice cannot tile, ...) a `ValueError` with the
/// runtime's one-line message.
pub(crate) fn render_error(e: RenderError) -> PyErr {
    match e {
        RenderError::Gpu(_) | RenderError::Volume(VolumeError::Gpu(_)) => PyRuntimeError::new_err(e.to_string()),
        e => value_error(e),
    }
}

/// The device for an adapter name (None: wgpu's choice), opened once.
pub(crate) fn gpu(adapter: Option<&str>) -> PyResult<Arc<Gpu>> {
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

/// A device budget in bytes from "64MiB", "2GiB", "512MB", "64KiB" or a
/// plain byte count (what `render --gpu-budget` takes).
fn parse_budget(text: &str) -> PyResult<u64> {
    boxforge_runtime::memory::parse_size(text).ok_or_else(|| {
        value_error(format!("gpu_budget {text:?}: give a size such as \"256MiB\", \"2GiB\" or 500000000 bytes"))
    })
}

/// `samples` (z, y, x) on the filter's lattice as `conversion` says
/// ("lattice": already its samples in the embedded layout; "subset": a
/// Cartesian volume's lattice points; "resample": a Cartesian volume
/// resampled at a matched count).
fn lattice_volume(samples: &PyReadonlyArray3<'_, f32>, d: &Derivation, conversion: &str) -> PyResult<LatticeVolume> {
    let s = samples.shape();
    let dims = [s[2], s[1], s[0]];
    let data = samples.as_slice().map_err(|_| value_error("samples: the array is not C-contiguous"))?.to_vec();
    crate::volume::finite(&data, dims, "render")?;
    let lattice = d.filter.lattice.clone();
    match conversion {
        "lattice" => Ok(LatticeVolume { lattice, dims, data }),
        "subset" | "resample" => {
            let how = if conversion == "subset" { Conversion::Subset } else { Conversion::Resample };
            let vol = Volume::new(dims, data).map_err(value_error)?;
            from_cartesian(&vol, &lattice, how).map_err(value_error)
        }
        other => Err(value_error(format!("conversion {other:?}: use lattice, subset or resample"))),
    }
}

/// What one frame draws.
enum Look {
    Iso(f32),
    /// The transfer function (None: the default ramp over the data's
    /// range, as the CLI picks it) and pre-integration.
    Dvr(Option<TransferFunction>, bool),
}

/// An image of `samples` (z, y, x) with the filter `spec`, as an (size,
/// size, 4) RGBA image (rows from the top): the isosurface at `iso`
/// (`mode` "iso") or a volume rendering (`mode` "dvr") with the transfer
/// function `tf` (a preset name or a JSON file; None: the CLI's default
/// ramp over the data's range), pre-integrated or not. `samples` are the
/// filter's lattice samples in the embedded layout (`conversion`
/// "lattice"), or Cartesian samples taken as their lattice subset
/// ("subset", the CLI's default) or resampled at a matched count
/// ("resample"). With `gpu_budget` (bytes, "64MiB", ...) the frame is drawn
/// out of core within that much device memory, from `samples` or, with
/// `store` instead, from level 0 of the OME-Zarr store at that path or URL
/// read brick by brick; `brick` is the brick edge in lattice texels.
#[pyfunction]
#[pyo3(signature = (samples, spec, mode = "iso", iso = 0.5, conversion = "subset", size = 512, azimuth = 30.0,
                    elevation = 25.0, perspective = false, layout = "embedded", tf = None, preintegrate = true,
                    gpu_budget = None, brick = None, store = None, adapter = None))]
#[allow(clippy::too_many_arguments)]
pub(crate) fn render_frame<'py>(
    py: Python<'py>,
    samples: Option<PyReadonlyArray3<'py, f32>>,
    spec: &str,
    mode: &str,
    iso: f32,
    conversion: &str,
    size: u32,
    azimuth: f32,
    elevation: f32,
    perspective: bool,
    layout: &str,
    tf: Option<&str>,
    preintegrate: bool,
    gpu_budget: Option<&str>,
    brick: Option<usize>,
    store: Option<&str>,
    adapter: Option<&str>,
) -> PyResult<Bound<'py, PyArray3<u8>>> {
    let d = crate::spec::derivation_of(py, spec)?;
    if d.facts.dim != 3 {
        return Err(value_error(format!("{} is {}D: render draws 3D filters", d.filter.name, d.facts.dim)));
    }
    let layout = Layout::parse(layout)
        .ok_or_else(|| value_error(format!("layout {layout:?}: use embedded, packed, bricked or bricked-packed")))?;
    if !(1..=8192).contains(&size) {
        return Err(value_error(format!("size {size}: give an image edge from 1 to 8192 pixels")));
    }
    if !azimuth.is_finite() || !elevation.is_finite() || elevation.abs() > 90.0 {
        return Err(value_error(format!(
            "azimuth {azimuth}, elevation {elevation}: give finite degrees, the elevation within -90..90"
        )));
    }
    let look = match mode {
        "iso" => {
            if !iso.is_finite() {
                return Err(value_error("iso: give a finite iso-value"));
            }
            if tf.is_some() || !preintegrate {
                return Err(value_error("tf and preintegrate are for mode=\"dvr\"; an isosurface takes iso"));
            }
            Look::Iso(iso)
        }
        "dvr" => {
            let tf = tf.map(TransferFunction::load).transpose().map_err(|e| value_error(format!("tf {e}")))?;
            Look::Dvr(tf, preintegrate)
        }
        other => {
            return Err(value_error(format!("mode {other:?}: use iso (an isosurface) or dvr (a volume rendering)")))
        }
    };
    let budget = gpu_budget.map(parse_budget).transpose()?;
    if budget.is_some() && layout == Layout::Packed {
        return Err(value_error(
            "gpu_budget stores the samples in bricks (the bricked layout); drop layout=\"packed\"",
        ));
    }
    match brick {
        Some(_) if budget.is_none() && !layout.is_bricked() => {
            return Err(value_error(
                "brick sizes the bricks of the bricked layout or of gpu_budget: add layout=\"bricked\" or gpu_budget, or drop brick",
            ))
        }
        Some(b) if !(2..=1024).contains(&b) => {
            return Err(value_error(format!("brick {b}: a brick edge is 2 to 1024 lattice texels, e.g. 32")))
        }
        _ => {}
    }
    let g = gpu(adapter)?;
    let frame = match (budget, samples, store) {
        (Some(budget), samples, store) => {
            let edge = brick.unwrap_or(BrickShape::DEFAULT_EDGE);
            let options = PagedOptions {
                iso,
                step: STEP,
                brick: edge,
                budget,
                max_pixels: size as u64 * size as u64,
                bounds_cache: None,
                ..Default::default()
            };
            let camera = Camera { size, azimuth, elevation, perspective };
            match (samples, store) {
                (Some(samples), None) => {
                    let v = lattice_volume(&samples, &d, conversion)?;
                    py.detach(|| paged(&g, &d, &v, options, look, &camera))
                }
                (None, Some(path)) => {
                    if conversion == "resample" {
                        return Err(value_error(
                            "gpu_budget reads the store lazily as it is (a Cartesian image as its lattice subset); resample needs the whole volume in memory: drop one of them",
                        ));
                    }
                    py.detach(|| -> PyResult<Frame> {
                        let image = OmeZarr::open(std::path::Path::new(path)).map_err(value_error)?;
                        let s = Selection { level: 0, channel: 0, time: 0 };
                        let source = ZarrVolume::new(&image, s, &d.filter.lattice).map_err(value_error)?;
                        paged(&g, &d, &source, options, look, &camera)
                    })
                }
                _ => return Err(value_error("give samples or a store, not both")),
            }?
        }
        (None, Some(samples), None) => {
            let v = lattice_volume(&samples, &d, conversion)?;
            let volume = VolumeOptions {
                bricks: BrickShape {
                    edge: brick.unwrap_or(BrickShape::DEFAULT_EDGE),
                    halo: boxforge::emit::bricks::brick_halo(&d),
                },
                ..Default::default()
            };
            py.detach(|| -> Result<Frame, RenderError> {
                match look {
                    Look::Iso(iso) => {
                        let o = RenderOptions {
                            iso,
                            width: size,
                            height: size,
                            azimuth,
                            elevation,
                            perspective,
                            step: STEP,
                            frames: 1,
                            volume,
                            ..Default::default()
                        };
                        boxforge_runtime::render::iso::render(&g, &d, &v, layout, &o)
                    }
                    Look::Dvr(tf, preintegrate) => {
                        // The CLI's default ramp in core: over the embedded volume's values.
                        let tf = tf.unwrap_or_else(|| {
                            let (lo, hi) = v
                                .data
                                .iter()
                                .fold((f32::INFINITY, f32::NEG_INFINITY), |(a, b), &x| (a.min(x), b.max(x)));
                            TransferFunction::ramp(lo as f64, hi as f64)
                        });
                        let o = DvrOptions {
                            frames: 1,
                            volume,
                            ..dvr_options(&Camera { size, azimuth, elevation, perspective }, preintegrate)
                        };
                        boxforge_runtime::render::dvr::render(&g, &d, &v, layout, &tf, &o)
                    }
                }
            })
            .map_err(render_error)?
        }
        _ => return Err(value_error("a store is drawn out of core (with gpu_budget); read it with boxforge.open")),
    };
    let (w, h) = (frame.width as usize, frame.height as usize);
    Ok(Array3::from_shape_vec((h, w, 4), frame.rgba).map_err(value_error)?.into_pyarray(py))
}

/// The frame's camera.
struct Camera {
    size: u32,
    azimuth: f32,
    elevation: f32,
    perspective: bool,
}

/// The DVR options of `render --mode dvr` for a frame (in core and out of core alike).
fn dvr_options(c: &Camera, preintegrate: bool) -> DvrOptions {
    DvrOptions {
        width: c.size,
        height: c.size,
        azimuth: c.azimuth,
        elevation: c.elevation,
        perspective: c.perspective,
        skip: true,
        skip_map: SkipMap::Distance,
        preintegrate,
        step: STEP,
        ..Default::default()
    }
}

/// One frame out of core, as `render --gpu-budget` draws it: the block
/// bounds brick row by brick row, then passes over a pool of bricks (the
/// default ramp over the source's range, as the CLI's).
fn paged(
    g: &Gpu,
    d: &Derivation,
    source: &dyn BrickSource,
    options: PagedOptions,
    look: Look,
    c: &Camera,
) -> PyResult<Frame> {
    let quiet = |_: usize, _: usize| {};
    let frame = match look {
        Look::Iso(_) => {
            let camera = RenderOptions {
                width: c.size,
                height: c.size,
                azimuth: c.azimuth,
                elevation: c.elevation,
                perspective: c.perspective,
                frames: 0,
                ..Default::default()
            };
            PagedIsoRenderer::new(g, d, source, options, &quiet).and_then(|mut r| r.render(source, &camera))
        }
        Look::Dvr(tf, preintegrate) => {
            let tf = match tf {
                Some(tf) => tf,
                None => {
                    let (lo, hi) = source.sample_range().map_err(value_error)?;
                    TransferFunction::ramp(lo as f64, hi as f64)
                }
            };
            let o = dvr_options(c, preintegrate);
            let look = DvrLook::from(&o);
            PagedDvrRenderer::new(g, d, source, tf.table(), look, options, &quiet)
                .and_then(|mut r| r.render(source, &o))
        }
    };
    frame.map(|(f, _)| f).map_err(render_error)
}
