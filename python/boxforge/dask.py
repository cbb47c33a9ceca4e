"""The volume passes on Dask arrays: lazily, chunk by chunk, each chunk with
the halo its output needs, so a volume too large for one machine is
prefiltered and resampled by a Dask cluster (``distributed``) and the result
equals the whole-volume result of :mod:`boxforge` and ``boxforge convert``,
bit for bit, seams included.

- :func:`prefilter` keeps the grid: ``map_overlap`` with the prefilter's
  reach as depth and no padding at the volume's edges (the Rust pass clamps
  there, as the whole-volume pass does).
- :func:`resample` changes the grid: each output chunk is one task that
  reads its own Cartesian footprint (its box times the scale, plus the
  trilinear stencil) from the input.

Arrays are ``(z, y, x)``, float32 in and out.
"""

from __future__ import annotations

import math
from typing import Any, Optional, Tuple

import dask
import dask.array as da
import numpy as np

from . import _boxforge, _spec_text

__all__ = ["prefilter", "resample"]


def _starts(chunks: Tuple[int, ...]) -> list:
    out, s = [], 0
    for c in chunks:
        out.append(s)
        s += c
    return out


def _at_least(chunks: Tuple[int, ...], d: int) -> Tuple[int, ...]:
    """Chunks along one axis, none thinner than ``d`` (unless the axis is)."""
    out: list = []
    for c in chunks:
        if out and (out[-1] < d or c < d):
            out[-1] += c
        else:
            out.append(c)
    return tuple(out)


def _prefilter_block(block: np.ndarray, spec: str, shape, starts, halo, block_info=None) -> np.ndarray:
    loc = block_info[0]["chunk-location"]
    # The block's origin in the volume: its chunk's start, less the halo
    # map_overlap put before it (none before the first chunk: boundary "none").
    origin = tuple(starts[a][loc[a]] - (halo[a] if loc[a] > 0 else 0) for a in range(3))
    return _boxforge.prefilter(np.ascontiguousarray(block, dtype=np.float32), spec, origin, shape)


def prefilter(samples: da.Array, spec: Any) -> da.Array:
    """Lattice samples (embedded layout, on the spec's lattice) prefiltered for the spec's filter,
    lazily: :func:`boxforge.prefilter` chunk by chunk with the taps' reach as halo."""
    spec = _spec_text(spec)
    x = _as_volume(samples, "prefilter")
    depth = _boxforge.prefilter_reach(spec)
    starts = [_starts(c) for c in x.chunks]
    if any(d > min(c) for d, c in zip(depth, x.chunks)):
        # A halo comes from the neighbouring chunk only: no chunk thinner than it.
        x = x.rechunk(tuple(_at_least(c, d) for c, d in zip(x.chunks, depth)))
        starts = [_starts(c) for c in x.chunks]
    return x.map_overlap(
        _prefilter_block,
        depth=dict(enumerate(depth)),
        boundary="none",
        dtype=np.float32,
        meta=np.empty((0, 0, 0), np.float32),
        spec=spec,
        shape=tuple(x.shape),
        starts=starts,
        halo=depth,
    )


def _resample_block(piece: np.ndarray, lattice: str, origin, shape, out_origin, out_shape) -> np.ndarray:
    return _boxforge.resample(np.ascontiguousarray(piece, dtype=np.float32), lattice, origin, shape, out_origin,
                              out_shape)


def resample(volume: da.Array, lattice: str, chunks: Optional[Any] = None) -> da.Array:
    """A Cartesian volume resampled on ``lattice`` at a matched sample count, lazily: one task per
    output chunk (``chunks``, default: the input's chunk shape scaled to the lattice box), each
    reading its own footprint of the input. Equals :func:`boxforge.resample` bit for bit."""
    x = _as_volume(volume, "resample")
    out_shape, scale = _boxforge.matched_lattice(lattice, tuple(x.shape))
    if chunks is None:
        chunks = tuple(max(1, round(c * o / n)) for c, o, n in zip(x.chunksize, out_shape, x.shape))
    out_chunks = da.core.normalize_chunks(chunks, out_shape, dtype=np.float32)
    starts = [_starts(c) for c in out_chunks]
    n = x.shape
    blocks = []
    for iz, cz in enumerate(out_chunks[0]):
        plane = []
        for iy, cy in enumerate(out_chunks[1]):
            row = []
            for ix, cx in enumerate(out_chunks[2]):
                lo = (starts[0][iz], starts[1][iy], starts[2][ix])
                size = (cz, cy, cx)
                # Trilinear reads voxels floor(j s) and floor(j s) + 1; one
                # voxel of margin each side covers rounding.
                f0 = tuple(max(0, math.floor(lo[a] * scale) - 1) for a in range(3))
                f1 = tuple(min(n[a], math.floor((lo[a] + size[a] - 1) * scale) + 3) for a in range(3))
                piece = x[f0[0]:f1[0], f0[1]:f1[1], f0[2]:f1[2]]
                task = dask.delayed(_resample_block, pure=True)(piece, lattice, f0, tuple(n), lo, size)
                row.append(da.from_delayed(task, shape=size, dtype=np.float32))
            plane.append(row)
        blocks.append(plane)
    return da.block(blocks)


def _as_volume(a: Any, what: str) -> da.Array:
    x = a if isinstance(a, da.Array) else da.asarray(a)
    if x.ndim != 3:
        raise ValueError(f"{what}: expected a 3D array (z, y, x), got shape {x.shape}")
    if not (np.issubdtype(x.dtype, np.floating) or np.issubdtype(x.dtype, np.integer)):
        raise ValueError(f"{what}: expected real samples, got dtype {x.dtype}")
    return x.astype(np.float32)
