"""boxforge from Python: box-spline filters on Cartesian, BCC and FCC lattices.

The heavy work runs in Rust (the same code as the ``boxforge`` command line,
not a second implementation), with the GIL released.

Arrays are NumPy ``float32`` volumes in ``(z, y, x)`` order (x varies
fastest, as NumPy's C order and the OME-Zarr axis order have it). Samples on
a BCC or FCC lattice are held in the *embedded* layout: an array over the
lattice's bounding box whose entries at non-lattice points are 0 (what
:func:`resample` returns and :func:`open` gives for a lattice store).

Specs are a catalog name (``"bcc7"``), a spec file's path, a spec's TOML
text, or a dict of the spec's fields (see ``docs/BOX_SPLINES.md``).
"""

from __future__ import annotations

import json
import os
from typing import Any, Mapping, NamedTuple, Optional, Tuple, Union

import numpy as np

from . import _boxforge

__version__ = _boxforge.__version__

Spec = Union[str, "os.PathLike[str]", Mapping[str, Any]]

__all__ = [
    "Spline",
    "Store",
    "bounds",
    "inspect",
    "lattice_of",
    "matched_lattice",
    "open",
    "prefilter",
    "render",
    "resample",
    "shader",
    "to_ome_zarr",
]


def _toml_value(v: Any) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, (int, float)):
        return repr(v)
    if isinstance(v, str):
        return json.dumps(v)
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(_toml_value(x) for x in v) + "]"
    raise ValueError(f"spec value {v!r}: give numbers, strings, booleans or lists of them")


def _spec_text(spec: Spec) -> str:
    """A spec as the extension takes it: a name, a path, or TOML text."""
    if isinstance(spec, Mapping):
        lines, tables = [], []
        for k, v in spec.items():
            if isinstance(v, Mapping):
                tables.append(f"[{k}]\n" + "".join(f"{kk} = {_toml_value(vv)}\n" for kk, vv in v.items()))
            else:
                lines.append(f"{k} = {_toml_value(v)}\n")
        return "".join(lines) + "".join(tables)
    if isinstance(spec, os.PathLike):
        return os.fspath(spec)
    if isinstance(spec, str):
        return spec
    raise ValueError(f"spec {spec!r}: give a catalog name, a spec file's path, TOML text or a dict")


def _volume(a: Any, what: str) -> np.ndarray:
    """``a`` as a C-contiguous float32 3D array (a copy only when needed)."""
    arr = np.asarray(a)
    if arr.ndim != 3:
        raise ValueError(f"{what}: expected a 3D array (z, y, x), got shape {arr.shape}")
    if 0 in arr.shape:
        raise ValueError(f"{what}: the array has an empty axis, shape {arr.shape}")
    if not (np.issubdtype(arr.dtype, np.floating) or np.issubdtype(arr.dtype, np.integer)):
        raise ValueError(f"{what}: expected real samples, got dtype {arr.dtype}")
    return np.ascontiguousarray(arr, dtype=np.float32)


def _zyx(t: Any, what: str) -> Tuple[int, int, int]:
    try:
        z, y, x = (int(v) for v in t)
    except Exception:
        raise ValueError(f"{what}: expected three whole numbers (z, y, x), got {t!r}") from None
    if min(z, y, x) < 0:
        raise ValueError(f"{what}: expected non-negative (z, y, x), got {t!r}")
    return (z, y, x)


def inspect(spec: Spec) -> dict:
    """The derivation report of a spec (what ``boxforge inspect --json`` prints) as a dict."""
    return json.loads(_boxforge.report_json(_spec_text(spec)))


def shader(spec: Spec, target: str = "wgsl", layout: str = "embedded") -> Tuple[str, list]:
    """The spec's shader module and its bindings (a list of dicts: group, binding, name, kind, ...).

    ``target`` is ``"wgsl"``; the other languages come from ``boxforge generate --target``.
    """
    if target != "wgsl":
        raise ValueError(f"target {target!r}: the Python package emits WGSL; for SPIR-V, GLSL, HLSL or MSL "
                         "run boxforge generate --target")
    source, bindings = _boxforge.shader(_spec_text(spec), layout)
    return source, json.loads(bindings)


def lattice_of(spec: Spec) -> str:
    """The name of the lattice the spec's filter is defined on (``"bcc"``, ``"fcc"``, ``"cc"``, ...)."""
    return _boxforge.lattice_of(_spec_text(spec))


def matched_lattice(lattice: str, shape: Tuple[int, int, int]) -> Tuple[Tuple[int, int, int], float]:
    """The lattice box (z, y, x) a Cartesian volume of ``shape`` is resampled on at a matched
    sample count, and the scale (Cartesian voxels per lattice unit)."""
    return _boxforge.matched_lattice(lattice, _zyx(shape, "shape"))


def resample(volume: Any, lattice: str) -> np.ndarray:
    """A Cartesian volume resampled on ``lattice`` (``"bcc"``, ``"fcc"``) at a matched sample count
    (trilinear, as ``boxforge render --resample`` and ``convert --lattice`` do): the embedded
    lattice volume, 0 off the lattice."""
    return _boxforge.resample(_volume(volume, "resample"), lattice)


def prefilter(samples: Any, spec: Spec) -> np.ndarray:
    """Lattice samples (embedded layout, on the spec's lattice) prefiltered for the spec's filter:
    its spline coefficients (quasi-interpolation), as ``convert --prefilter`` stores them."""
    return _boxforge.prefilter(_volume(samples, "prefilter"), _spec_text(spec))


class Spline:
    """The box spline of a spec, evaluated on the CPU with the generator's exact evaluator (f64,
    the path the shaders take), on lattice samples in the embedded layout (fetched clamped into
    their box, as the shaders fetch them).

    Points are an (N, 3) array of (z, y, x) positions in sample units (sample ``[k, j, i]`` at
    ``(k, j, i)``); derivatives are along (z, y, x). Work is spread over every core with the GIL
    released. A ``Spline`` pickles as its spec (Dask ships it to workers).
    """

    def __init__(self, spec: Spec):
        self.spec = _spec_text(spec)
        self.lattice = lattice_of(self.spec)

    def __reduce__(self):
        return (Spline, (self.spec,))

    def __repr__(self) -> str:
        return f"boxforge.Spline({self.spec!r})"

    def _eval(self, points: Any, samples: Any, order: int):
        p = np.ascontiguousarray(points, dtype=np.float64)
        if p.ndim == 1 and p.shape[0] == 3:
            p = p[None, :]
        if p.ndim != 2 or p.shape[1] != 3:
            raise ValueError(f"points: expected an (N, 3) array of (z, y, x), got shape {p.shape}")
        return _boxforge.spline_eval(self.spec, p, _volume(samples, "samples"), order)

    def eval(self, points: Any, samples: Any) -> np.ndarray:
        """The spline's values at the points, shape (N,)."""
        return self._eval(points, samples, 0)[0]

    def grad(self, points: Any, samples: Any) -> np.ndarray:
        """The gradients (d/dz, d/dy, d/dx) at the points, shape (N, 3)."""
        return self._eval(points, samples, 1)[1]

    def hessian(self, points: Any, samples: Any) -> np.ndarray:
        """The Hessians (z, y, x order) at the points, shape (N, 3, 3)."""
        return self._eval(points, samples, 2)[2]


class Store(NamedTuple):
    """One level of an OME-Zarr store, read whole."""

    #: The samples (z, y, x): the image, or for a lattice store its embedded lattice volume.
    samples: np.ndarray
    #: The lattice the samples are on (``"cc"`` for an image).
    lattice: str
    #: The voxel size (z, y, x) of the samples' grid, in ``unit``.
    spacing: Tuple[float, float, float]
    #: The space unit the store names, if any (``"millimeter"``, ...).
    unit: Optional[str]
    #: The filter the samples were prefiltered for, if any (they are its spline coefficients).
    prefilter: Optional[str]


def open(store: Union[str, "os.PathLike[str]"], level: int = 0, channel: int = 0, time: int = 0) -> Store:
    """Reads a level of an OME-Zarr image (0.4 or 0.5; a folder or an ``http://`` URL), or of a
    store of lattice samples written by :func:`to_ome_zarr` or ``boxforge convert --lattice``."""
    samples, lattice, spacing, unit, pre = _boxforge.open_level(os.fspath(store), level, channel, time)
    return Store(samples, lattice, spacing, unit, pre)


def to_ome_zarr(
    volume: Any,
    store: Union[str, "os.PathLike[str]"],
    lattice: Optional[str] = None,
    prefilter: Optional[Spec] = None,
    chunk: int = 64,
    shard: Optional[int] = None,
    levels: Optional[int] = None,
    reduction: str = "box",
    dtype: Optional[str] = None,
    spacing: Tuple[float, float, float] = (1.0, 1.0, 1.0),
    unit: Optional[str] = None,
) -> list:
    """Writes a Cartesian volume (z, y, x) as an OME-Zarr 0.5 pyramid at ``store`` (a new or empty
    folder), as ``boxforge convert`` does: of its samples, or with ``lattice`` / ``prefilter`` of
    lattice samples stored as their Cartesian cosets (docs/OME_ZARR.md). Returns each level's
    shape (z, y, x): the image's, or the lattice box's."""
    pre = None if prefilter is None else _spec_text(prefilter)
    return _boxforge.write_store(
        _volume(volume, "to_ome_zarr"), os.fspath(store), lattice, pre, chunk, shard, levels, reduction, dtype,
        tuple(float(s) for s in spacing), unit,
    )


def render(
    volume: Any,
    spec: Spec,
    iso: Optional[float] = None,
    size: int = 512,
    azimuth: float = 30.0,
    elevation: float = 25.0,
    perspective: bool = False,
    resample: bool = False,
    on_lattice: bool = False,
    layout: str = "embedded",
    adapter: Optional[str] = None,
    mode: str = "iso",
    tf: Optional[Union[str, "os.PathLike[str]"]] = None,
    preintegrate: bool = True,
    gpu_budget: Optional[Union[int, str]] = None,
    brick: Optional[int] = None,
) -> np.ndarray:
    """An image drawn with the spec's filter by the runtime's ray casters (what ``boxforge render``
    draws for the same arguments, on lavapipe or any GPU wgpu finds): a (size, size, 4) uint8 RGBA
    image, rows from the top.

    ``mode="iso"`` draws the isosurface at ``iso``; ``mode="dvr"`` a volume rendering
    (emission-absorption, ``--mode dvr``) with the transfer function ``tf``: a preset name
    (``"mni-tissue"``, ``"mni-opaque"``, ``"marschner-lobb"``) or a JSON file, by default the CLI's
    ramp over the data's range; ``preintegrate=False`` point-samples it instead.

    ``gpu_budget`` (bytes, or a size such as ``"64MiB"`` or ``"2GiB"``) draws the frame out of core
    as ``render --gpu-budget`` does: bricks of ``brick`` lattice texels (default 32) paged into a
    pool that fits the budget; a store's path is then read brick by brick, never whole. A budget
    below what the renderer needs is a ``ValueError`` saying how much to give.

    ``volume`` is a Cartesian array (z, y, x), taken as its lattice subset (the default) or, with
    ``resample``, resampled at a matched sample count; an array already on the filter's lattice
    (embedded layout) with ``on_lattice``; a :class:`Store`; or a store's path or URL (its level 0).
    The camera orbits the volume: ``azimuth`` and ``elevation`` in degrees."""
    if mode == "iso" and iso is None:
        raise ValueError("iso: give the iso-value of the isosurface (or mode=\"dvr\" for a volume rendering)")
    if mode == "dvr" and iso is not None:
        raise ValueError("iso: a volume rendering (mode=\"dvr\") draws with tf, not an iso-value: drop iso")
    budget = None if gpu_budget is None else str(gpu_budget)
    store = None
    if isinstance(volume, (str, os.PathLike)):
        if budget is None:
            volume = open(volume)
        else:
            store = os.fspath(volume)
    if isinstance(volume, Store):
        if volume.lattice != "cc":
            on_lattice = True
        volume = volume.samples
    if resample and on_lattice:
        raise ValueError("resample: the samples are on the lattice already; drop resample")
    conversion = "lattice" if on_lattice else ("resample" if resample else "subset")
    samples = None if store is not None else _volume(volume, "render")
    return _boxforge.render_frame(
        samples, _spec_text(spec), mode, 0.5 if iso is None else float(iso), conversion, int(size), float(azimuth),
        float(elevation), bool(perspective), layout, None if tf is None else os.fspath(tf), bool(preintegrate),
        budget, None if brick is None else int(brick), store, adapter,
    )


def bounds(samples: Any, spec: Spec, brick: int = 32, adapter: Optional[str] = None) -> np.ndarray:
    """The [min, max] of the spec's spline over each brick of ``brick``^3 unit cubes, by the
    runtime's own pass (the bounds ``boxforge render --gpu-budget`` computes before its first frame
    to skip empty space), on lavapipe or any GPU wgpu finds.

    ``samples`` are the filter's lattice samples in the embedded layout (as :class:`Spline` takes
    them: a Cartesian array's non-lattice entries are not read). Brick ``[kz, ky, kx]`` spans the
    positions ``k * brick .. (k + 1) * brick`` along (z, y, x) in sample units; the bricks of the
    last row reach past the volume over its samples clamped into it. The bounds are those of the
    Bernstein coefficients of every polynomial piece over the brick (convex hull property), each
    computed from the samples of its stencil, so every value of the spline in the brick lies in
    them, including what the samples of the brick's halo contribute. ``brick`` must be a multiple of
    the lattice's period (2 for BCC and FCC).

    Returns a float32 array of shape (bz, by, bx, 2): ``[..., 0]`` the minimum, ``[..., 1]`` the
    maximum, bricks in (z, y, x) order."""
    return _boxforge.bounds(_volume(samples, "bounds"), _spec_text(spec), int(brick), adapter)
