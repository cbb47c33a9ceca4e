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
- :func:`bounds` keeps the brick grid: ``map_overlap`` over chunks of
  whole bricks with a halo of whole bricks covering the filter's support.
- :func:`reduce` makes the next pyramid level the same way (its box
  doubled plus the reduction's taps).
- :func:`to_ome_zarr` writes the store ``boxforge convert`` writes, the
  same bytes, one task per store write unit (chunk or shard), each reading
  its footprint of the level it is made from out of the store being
  written and writing its unit straight from the worker (the path must be
  one they all see), the metadata last; :func:`store_stages` is that work
  as Dask collections.

Arrays are ``(z, y, x)``, float32 in and out.
"""

from __future__ import annotations

import functools
import json
import math
import os
from typing import Any, List, Optional, Tuple

import dask
import dask.array as da
import numpy as np

from . import _boxforge, _spec_text

__all__ = ["bounds", "prefilter", "reduce", "resample", "store_stages", "to_ome_zarr"]


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


def _resample_block(piece: np.ndarray, origin, lo, size, lattice: str, shape) -> np.ndarray:
    return _boxforge.resample(np.ascontiguousarray(piece, dtype=np.float32), lattice, origin, shape, lo, size)


def resample(volume: da.Array, lattice: str, chunks: Optional[Any] = None) -> da.Array:
    """A Cartesian volume resampled on ``lattice`` at a matched sample count, lazily: one task per
    output chunk (``chunks``, default: the input's chunk shape scaled to the lattice box), each
    reading its own footprint of the input. Equals :func:`boxforge.resample` bit for bit."""
    x = _as_volume(volume, "resample")
    out_shape, scale = _boxforge.matched_lattice(lattice, tuple(x.shape))
    if chunks is None:
        chunks = tuple(max(1, round(c * o / n)) for c, o, n in zip(x.chunksize, out_shape, x.shape))
    out_chunks = da.core.normalize_chunks(chunks, out_shape, dtype=np.float32)
    n = tuple(x.shape)

    def reach(lo, size):
        # Trilinear reads voxels floor(j s) and floor(j s) + 1; one voxel
        # of margin each side covers rounding.
        f0 = tuple(max(0, math.floor(lo[a] * scale) - 1) for a in range(3))
        f1 = tuple(min(n[a], math.floor((lo[a] + size[a] - 1) * scale) + 3) for a in range(3))
        return f0, f1

    return _footprint_tasks(x, out_shape, out_chunks, reach, functools.partial(_resample_block, lattice=lattice,
                                                                                 shape=n))


def _bounds_block(block: np.ndarray, spec: str, brick: int, halo, block_info=None) -> np.ndarray:
    loc, n = block_info[0]["chunk-location"], block_info[0]["num-chunks"]
    b = _boxforge.bounds(np.ascontiguousarray(block, dtype=np.float32), spec, brick, None)
    # The halo's bricks (none before the first chunk or past the last) are
    # another chunk's: keep this chunk's own.
    cut = tuple(slice(halo[a] // brick if loc[a] > 0 else 0,
                      b.shape[a] - (halo[a] // brick if loc[a] < n[a] - 1 else 0)) for a in range(3))
    return b[cut]


def bounds(samples: da.Array, spec: Any, brick: int = 32) -> da.Array:
    """:func:`boxforge.bounds` lazily, chunk by chunk: chunks rounded to
    whole bricks, each with a halo of whole bricks covering the filter's
    reach (its support), so every brick's bounds equal the whole volume's.
    Returns a (bz, by, bx, 2) float32 dask array, one chunk per input chunk."""
    spec = _spec_text(spec)
    x = _as_volume(samples, "bounds")
    report = json.loads(_boxforge.report_json(spec))
    if report["dimension"] != 3:
        raise ValueError(f"{report['name']} is {report['dimension']}D: bounds are computed for 3D filters")
    if brick < 1:
        raise ValueError(f"brick {brick}: give a brick edge from 1 to 1024")
    # A unit cube's stencil reaches the support's half-extent past it.
    directions = report["directions"]
    reach = [math.ceil(sum(abs(d[a]) for d in directions) / 2) + 1 for a in (2, 1, 0)]
    depth = tuple(brick * math.ceil(r / brick) for r in reach)
    chunks = tuple(brick * max(1, round(c / brick)) for c in x.chunksize)
    x = x.rechunk(da.core.normalize_chunks(chunks, x.shape))
    if any(d > min(c) for d, c in zip(depth, x.chunks)):
        x = x.rechunk(tuple(_at_least(c, d) for c, d in zip(x.chunks, depth)))
    out_chunks = tuple(tuple(math.ceil(c / brick) for c in cs) for cs in x.chunks) + ((2,),)
    return x.map_overlap(_bounds_block, depth=dict(enumerate(depth)), boundary="none", trim=False,
                         dtype=np.float32, chunks=out_chunks, new_axis=3, meta=np.empty((0, 0, 0, 0), np.float32),
                         spec=spec, brick=brick, halo=depth)


def _footprint_tasks(x: da.Array, out_shape, out_chunks, reach, task):
    """One task per output chunk, each given the input box it reads:
    ``reach(lo, size)`` -> the input box ``(f0, f1)`` (f1 exclusive)."""
    starts = [_starts(c) for c in out_chunks]
    blocks = []
    for iz, cz in enumerate(out_chunks[0]):
        plane = []
        for iy, cy in enumerate(out_chunks[1]):
            row = []
            for ix, cx in enumerate(out_chunks[2]):
                lo = (starts[0][iz], starts[1][iy], starts[2][ix])
                size = (cz, cy, cx)
                f0, f1 = reach(lo, size)
                piece = x[f0[0]:f1[0], f0[1]:f1[1], f0[2]:f1[2]]
                t = dask.delayed(task, pure=True)(piece, f0, lo, size)
                row.append(da.from_delayed(t, shape=size, dtype=np.float32))
            plane.append(row)
        blocks.append(plane)
    return da.block(blocks)


def _reduce_block(piece: np.ndarray, origin, lo, size, reduction: str, shape) -> np.ndarray:
    return _boxforge.reduce(np.ascontiguousarray(piece, dtype=np.float32), reduction, origin, shape, lo, size)


def _next_len(n: int, reduction: str) -> int:
    return max(n // 2, 1) if reduction == "box" else (n + 1) // 2


def reduce(volume: da.Array, reduction: str = "box", chunks: Optional[Any] = None) -> da.Array:
    """The next level of a pyramid (the store writer's ``reduction``: box,
    subsample, tent or binomial), lazily: one task per output chunk
    (``chunks``, default: the input's chunk shape), each reading its
    footprint. Equals the level ``boxforge convert`` stores, bit for bit."""
    x = _as_volume(volume, "reduce")
    if reduction not in ("box", "subsample", "tent", "binomial"):
        raise ValueError(f"reduction {reduction!r}: use box, subsample, tent or binomial")
    n = tuple(x.shape)
    out_shape = tuple(_next_len(k, reduction) for k in n)
    out_chunks = da.core.normalize_chunks(chunks or x.chunksize, out_shape, dtype=np.float32)

    def reach(lo, size):
        # Samples 2i - 2 ..= 2i + 2 cover every reduction's taps (mirrored
        # positions included).
        f0 = tuple(max(0, min(2 * lo[a] - 2, n[a] - 1)) for a in range(3))
        f1 = tuple(min(n[a], 2 * (lo[a] + size[a] - 1) + 3) for a in range(3))
        return f0, f1

    return _footprint_tasks(x, out_shape, out_chunks, reach, functools.partial(_reduce_block, reduction=reduction,
                                                                                 shape=n))


def _write_cartesian(block: np.ndarray, plan, block_info=None) -> np.ndarray:
    loc = block_info[0]["array-location"]
    plan.write_cartesian(np.ascontiguousarray(block, dtype=np.float32), tuple(r[0] for r in loc))
    return np.zeros((1, 1, 1), np.uint8)


def _write_reduced(plan, level: int, unit: int) -> None:
    plan.write_reduced(level, unit)


def _write_lattice(plan, level: int, unit: int) -> None:
    plan.write_lattice(level, unit)


def store_stages(volume: Any, plan) -> List[List[Any]]:
    """The work of writing ``plan``'s store from ``volume``, in stages that
    run one after the other (each reads what the one before it wrote), each
    a list of Dask collections: level 0 of the Cartesian pyramid from the
    volume, in write units; then each coarser level, one task per write
    unit reading its footprint of the level before it from the store; then,
    for a lattice store, every lattice unit, one task each, reading its
    footprint of the Cartesian level (resampled and prefiltered in the
    task). Tasks pass nothing to each other but the store, so a worker
    holds one unit and its footprint at a time, whatever the volume."""
    x = _as_volume(volume, "to_ome_zarr")
    if tuple(x.shape) != tuple(plan.cartesian_levels[0]):
        raise ValueError(f"to_ome_zarr: the volume's shape {x.shape} is not the plan's {plan.cartesian_levels[0]}")
    first = x.rechunk(plan.cartesian_block).map_blocks(_write_cartesian, plan=plan, dtype=np.uint8, chunks=(1, 1, 1),
                                                        meta=np.empty((0, 0, 0), np.uint8))
    stages: List[List[Any]] = [[first]]
    for k in range(1, len(plan.cartesian_levels)):
        stages.append([dask.delayed(_write_reduced, pure=False)(plan, k, i)
                       for i in range(plan.unit_count(k, cartesian=True))])
    if plan.lattice is not None:
        stages.append([dask.delayed(_write_lattice, pure=False)(plan, k, i)
                       for k in range(len(plan.levels)) for i in range(plan.unit_count(k))])
    return stages


def to_ome_zarr(volume: Any, path: Any, spec: Any = None, *, lattice: Optional[str] = None, chunk: int = 64,
                shard: Optional[int] = None, levels: Optional[int] = None, reduction: str = "box",
                dtype: Optional[str] = None, spacing: Tuple[float, float, float] = (1.0, 1.0, 1.0),
                unit: Optional[str] = None) -> List[Tuple[int, int, int]]:
    """Writes the Cartesian ``volume`` (z, y, x; a Dask array, or anything
    ``dask.array.asarray`` takes) at ``path`` as the OME-Zarr pyramid
    ``boxforge convert`` writes with the same options: with ``spec``, each
    level resampled on the spec's lattice (or ``lattice``) and prefiltered
    for it (``--lattice L --prefilter SPEC``); with ``lattice`` alone,
    resampled only; with neither, the Cartesian samples. The same bytes as
    the CLI's store, file for file: every unit goes through the same Rust
    code (``StorePlan``) as ``convert``'s.

    The work runs on the current Dask scheduler (a ``distributed.Client``'s
    cluster if one is active) in the stages of :func:`store_stages`, each
    write unit written by the task that computed it, so ``path`` must be a
    folder every worker sees (a shared file system on a multi-machine
    cluster). The store is complete (its metadata written, a lattice
    store's hidden Cartesian pass removed) when the levels come back:
    each level's stored samples (z, y, x).
    """
    x = _as_volume(volume, "to_ome_zarr")
    filter_spec = _spec_text(spec) if spec is not None else None
    plan = _boxforge.StorePlan(os.fspath(path), tuple(x.shape), lattice=lattice, prefilter=filter_spec, chunk=chunk,
                               shard=shard, levels=levels, reduction=reduction, dtype=dtype,
                               spacing=tuple(float(s) for s in spacing), unit=unit)
    stages = store_stages(x, plan)
    plan.create()
    for k, stage in enumerate(stages):
        dask.compute(*stage)
        if plan.lattice is not None and k == len(plan.cartesian_levels) - 1:
            plan.finish_cartesian()
    return plan.finish()


def _as_volume(a: Any, what: str) -> da.Array:
    x = a if isinstance(a, da.Array) else da.asarray(a)
    if x.ndim != 3:
        raise ValueError(f"{what}: expected a 3D array (z, y, x), got shape {x.shape}")
    if not (np.issubdtype(x.dtype, np.floating) or np.issubdtype(x.dtype, np.integer)):
        raise ValueError(f"{what}: expected real samples, got dtype {x.dtype}")
    return x.astype(np.float32)
