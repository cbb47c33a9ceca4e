//! Per-brick bounds of a spline from Python: the runtime's own min/max
//! pass (`render::paged::bounds::brick_row_bounds`, what `render
//! --gpu-budget` computes before its first frame), run on the device over
//! the samples a brick row at a time with the filter's halo.

use crate::render::{gpu, render_error};
use boxforge::emit::SampleMap;
use boxforge_runtime::render::paged::bounds::{brick_row_bounds, lattice_period};
use boxforge_runtime::volume::{LatticeVolume, SampleFormat};
use numpy::ndarray::Array4;
use numpy::{IntoPyArray, PyArray4, PyReadonlyArray3, PyUntypedArrayMethods};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;

/// Device texels one slab of brick rows may take (64 MiB of f32).
const MAX_TEXELS: usize = 1 << 24;

/// The [min, max] of the spline of `samples` (z, y, x, the filter's lattice
/// samples in the embedded layout) with the filter `spec` over each brick
/// of `brick`^3 unit cubes: brick (kz, ky, kx) spans the positions
/// [k brick, (k + 1) brick] on each axis (the last brick of an axis reaches
/// past the volume, over the samples clamped into it, as the shaders fetch
/// them). The runtime's bounds: the min and max of the Bernstein
/// coefficients of every polynomial piece over the brick (convex hull
/// property), each piece's from the samples of its stencil, so the brick's
/// halo (the filter's reach) is covered. Shape (bz, by, bx, 2), float32.
#[pyfunction]
#[pyo3(signature = (samples, spec, brick = 32, adapter = None))]
pub(crate) fn bounds<'py>(
    py: Python<'py>,
    samples: PyReadonlyArray3<'py, f32>,
    spec: &str,
    brick: usize,
    adapter: Option<&str>,
) -> PyResult<Bound<'py, PyArray4<f32>>> {
    let d = crate::spec::derivation_of(py, spec)?;
    if d.facts.dim != 3 {
        return Err(PyValueError::new_err(format!(
            "{} is {}D: bounds are computed for 3D filters",
            d.filter.name, d.facts.dim
        )));
    }
    let period = lattice_period(&d.filter.lattice);
    if !(1..=1024).contains(&brick) || !brick.is_multiple_of(period) {
        return Err(PyValueError::new_err(format!(
            "brick {brick}: give a brick edge from 1 to 1024 that is a multiple of the {} lattice's period {period} (e.g. 32)",
            d.filter.lattice.name
        )));
    }
    let s = samples.shape();
    let dims = [s[2], s[1], s[0]];
    let data =
        samples.as_slice().map_err(|_| PyValueError::new_err("samples: the array is not C-contiguous"))?.to_vec();
    if let Some(v) = data.iter().find(|v| !v.is_finite()) {
        return Err(PyValueError::new_err(format!("samples: the array holds {v}; bounds need finite samples")));
    }
    let volume = LatticeVolume { lattice: d.filter.lattice.clone(), dims, data };
    // Blocks of at most 4^3 cubes (one invocation each, as the renderers
    // bound them), merged into bricks here: min and max are exact in f32,
    // so a brick's bounds are those of one block of the brick's edge.
    let block = (1..=4).rev().find(|b| brick.is_multiple_of(*b)).unwrap_or(1);
    let g = gpu(adapter)?;
    let blocks = py
        .detach(|| {
            brick_row_bounds(
                &g,
                &d,
                &volume,
                SampleFormat::F32,
                SampleMap::IDENTITY,
                brick,
                block,
                MAX_TEXELS,
                &|_, _| {},
            )
        })
        .map_err(render_error)?;
    let nb = dims.map(|n| n.div_ceil(block));
    let nk = dims.map(|n| n.div_ceil(brick));
    let per = brick / block;
    let mut out =
        Array4::from_shape_fn(
            (nk[2], nk[1], nk[0], 2),
            |(_, _, _, i)| {
                if i == 0 {
                    f32::INFINITY
                } else {
                    f32::NEG_INFINITY
                }
            },
        );
    for z in 0..nb[2] {
        for y in 0..nb[1] {
            for x in 0..nb[0] {
                let [lo, hi] = blocks[x + nb[0] * (y + nb[1] * z)];
                let (kz, ky, kx) = (z / per, y / per, x / per);
                out[[kz, ky, kx, 0]] = out[[kz, ky, kx, 0]].min(lo);
                out[[kz, ky, kx, 1]] = out[[kz, ky, kx, 1]].max(hi);
            }
        }
    }
    Ok(out.into_pyarray(py))
}
