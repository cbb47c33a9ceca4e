#!/usr/bin/env python3
"""Writes the OME-Zarr fixture stores under runtime/tests/fixtures/ome-zarr/
with the `ome_zarr` package (an implementation independent of boxforge).

Run by hand in a venv made from requirements-fixture.txt (see README.md).
Its output is committed; rerunning it rewrites the stores from scratch.

Sample values (level 0), for index (t, c, z, y, x) (missing axes are 0):
    v = (3*x + 5*y + 7*z + 11*c + 13*t) % 200
    uint16: v        float32: v + 0.25        int16: v - 100
Level k >= 1 is level k-1 subsampled as a[..., ::2, ::2, ::2], so level k at
index i equals level 0 at index i * 2**k (along z, y, x; t and c unchanged).
The scale transform of level k is the level-0 scale times 2**k along z, y, x
(no translation), written explicitly (not derived by ome_zarr from shapes).
"""
import json
import os
import shutil
import sys
import warnings

import numpy as np
import zarr
from numcodecs import Blosc
from zarr.codecs import ZstdCodec

from ome_zarr.format import FormatV04, FormatV05
from ome_zarr.writer import write_multiscale

HERE = os.path.dirname(os.path.abspath(__file__))
REPO = os.path.abspath(os.path.join(HERE, "..", ".."))
OUT = os.path.join(REPO, "runtime", "tests", "fixtures", "ome-zarr")


def level0(axes, shape, dtype):
    """The closed formula over an array with the given axis names and shape."""
    coeff = {"x": 3, "y": 5, "z": 7, "c": 11, "t": 13}
    grids = np.indices(shape, dtype=np.int64)
    v = np.zeros(shape, dtype=np.int64)
    for name, g in zip(axes, grids):
        v += coeff[name] * g
    v %= 200
    dtype = np.dtype(dtype)
    if dtype == np.float32:
        return (v.astype(np.float32) + np.float32(0.25)).astype(np.float32)
    if dtype == np.int16:
        return (v - 100).astype(np.int16)
    if dtype == np.uint16:
        return v.astype(np.uint16)
    raise ValueError(dtype)


def pyramid(a, levels):
    out = [a]
    for _ in range(1, levels):
        out.append(np.ascontiguousarray(out[-1][..., ::2, ::2, ::2]))
    return out


def transforms(axes, scale0, levels):
    out = []
    for k in range(levels):
        s = [
            float(scale0[n] * (2**k if n in ("z", "y", "x") else 1))
            for n in axes
        ]
        out.append([{"type": "scale", "scale": s}])
    return out


def write(name, fmt, axes, units, shape, dtype, scale0, levels, storage_options):
    path = os.path.join(OUT, name)
    if os.path.exists(path):
        shutil.rmtree(path)
    data = pyramid(level0(axes, shape, dtype), levels)
    group = zarr.open_group(path, mode="w", zarr_format=fmt.zarr_format)
    axes_meta = [
        {"name": n, "type": {"t": "time", "c": "channel"}.get(n, "space"),
         **({"unit": units[n]} if n in units else {})}
        for n in axes
    ]
    with warnings.catch_warnings():
        # `coordinate_transformations` is deprecated in favour of `scale`, but
        # `scale` derives coarser levels' scales from shape ratios (10 -> 5 -> 3
        # would give 3.33, not 4), so we pass exact transforms ourselves.
        warnings.simplefilter("ignore", DeprecationWarning)
        write_multiscale(
            data,
            group,
            fmt=fmt,
            axes=axes_meta,
            coordinate_transformations=transforms(axes, scale0, levels),
            storage_options=storage_options,
            name=name.removesuffix(".zarr"),
        )
    # Self-check: read back every level and compare with the formula.
    g = zarr.open_group(path, mode="r")
    for k, expect in enumerate(data):
        got = g[f"s{k}"][...]
        assert got.dtype == expect.dtype and np.array_equal(got, expect), (name, k)
        full = level0(axes, shape, dtype)
        idx = tuple(
            slice(None, None, 2**k) if n in ("z", "y", "x") else slice(None)
            for n in axes
        )
        assert np.array_equal(got, full[idx]), (name, k)
    print(f"wrote {path}: " + ", ".join(f"s{k} {a.shape}" for k, a in enumerate(data)))


def main():
    os.makedirs(OUT, exist_ok=True)
    um = "micrometer"

    # OME-Zarr 0.4 on Zarr v2: uint16, z,y,x, 3 levels, blosc zstd.
    write(
        "v04-u16.zarr", FormatV04(), ["z", "y", "x"],
        {"z": um, "y": um, "x": um},
        (12, 10, 16), np.uint16, {"z": 2.0, "y": 1.0, "x": 1.0}, 3,
        {"chunks": (8, 8, 8),
         "compressor": Blosc(cname="zstd", clevel=5, shuffle=Blosc.SHUFFLE)},
    )

    # OME-Zarr 0.5 on Zarr v3: float32, c,z,y,x, 2 levels, zstd, sharded.
    write(
        "v05-f32-czyx.zarr", FormatV05(), ["c", "z", "y", "x"],
        {"z": um, "y": um, "x": um},
        (2, 12, 10, 16), np.float32, {"c": 1.0, "z": 2.0, "y": 1.0, "x": 1.0}, 2,
        {"chunks": (1, 8, 8, 8), "shards": (1, 16, 16, 16),
         "compressor": ZstdCodec(level=3)},
    )

    # OME-Zarr 0.5 on Zarr v3: int16, t,c,z,y,x, 1 level, zstd, not sharded.
    write(
        "v05-i16-tczyx.zarr", FormatV05(), ["t", "c", "z", "y", "x"],
        {"t": "second", "z": um, "y": um, "x": um},
        (2, 1, 8, 8, 8), np.int16,
        {"t": 1.0, "c": 1.0, "z": 1.0, "y": 1.0, "x": 1.0}, 1,
        {"chunks": (1, 1, 8, 8, 8), "compressor": ZstdCodec(level=3)},
    )


if __name__ == "__main__":
    sys.exit(main())
