#!/usr/bin/env python3
"""Validates an OME-Zarr image store with ome-zarr-models and summarises it.

Usage: check_store.py STORE [--raw-out DIR]

Picks the ome-zarr-models Image model (v04 or v05) from the store's own
metadata ("multiscales"[0]["version"] on Zarr v2, "ome"["version"] on Zarr v3),
validates the group with it, then reads every level of the first multiscale
with zarr and prints one JSON line on stdout:

  {"version": "0.4"|"0.5", "axes": [names],
   "levels": [{"path", "shape", "dtype", "scale", "sha256"}]}

"scale" is the level's scale transform times the multiscale-wide scale
transform when there is one. "sha256" is the hash of the level's full array as
C-order little-endian bytes. With --raw-out DIR those bytes are also written to
DIR/<path>.raw. On any failure: one line on stderr and exit status 1.
"""
import argparse
import hashlib
import json
import os
import sys

import numpy as np
import zarr

import ome_zarr_models
from ome_zarr_models.v04.image import Image as ImageV04
from ome_zarr_models.v05.image import Image as ImageV05


def fail(msg):
    one_line = " | ".join(l.strip() for l in str(msg).splitlines() if l.strip())
    print(f"check_store: {one_line}", file=sys.stderr)
    sys.exit(1)


def scale_of(transforms, ndim):
    for t in transforms or ():
        if t.type == "scale":
            return [float(s) for s in t.scale]
    return [1.0] * ndim


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("store")
    ap.add_argument("--raw-out", metavar="DIR")
    args = ap.parse_args()

    try:
        group = zarr.open_group(args.store, mode="r")
    except Exception as e:
        fail(f"{args.store}: not a zarr group: {type(e).__name__}: {e}")
    attrs = group.attrs.asdict()
    try:
        if "ome" in attrs:
            version = attrs["ome"]["version"]
        else:
            version = attrs["multiscales"][0]["version"]
    except Exception:
        fail(f"{args.store}: no OME-Zarr image metadata (ome.version or multiscales[0].version)")
    model_cls = {"0.4": ImageV04, "0.5": ImageV05}.get(version)
    if model_cls is None:
        fail(f"{args.store}: unsupported OME-Zarr version {version!r}")
    try:
        image = model_cls.from_zarr(group)
    except Exception as e:
        fail(f"{args.store}: invalid OME-Zarr {version} image "
             f"(ome-zarr-models {ome_zarr_models.__version__}): {type(e).__name__}: {e}")

    ms = image.ome_attributes.multiscales[0]
    axes = [a.name for a in ms.axes]
    global_scale = scale_of(ms.coordinateTransformations, len(axes))
    if args.raw_out:
        os.makedirs(args.raw_out, exist_ok=True)
    levels = []
    for ds in ms.datasets:
        try:
            arr = group[ds.path]
            data = arr[...]
        except Exception as e:
            fail(f"{args.store}: cannot read level {ds.path}: {type(e).__name__}: {e}")
        data = np.ascontiguousarray(data, dtype=data.dtype.newbyteorder("<"))
        raw = data.tobytes(order="C")
        if args.raw_out:
            dest = os.path.join(args.raw_out, ds.path + ".raw")
            os.makedirs(os.path.dirname(dest), exist_ok=True)
            with open(dest, "wb") as f:
                f.write(raw)
        scale = scale_of(ds.coordinateTransformations, len(axes))
        levels.append({
            "path": ds.path,
            "shape": list(data.shape),
            "dtype": data.dtype.name,
            "scale": [a * b for a, b in zip(scale, global_scale)],
            "sha256": hashlib.sha256(raw).hexdigest(),
        })
    print(json.dumps({"version": version, "axes": axes, "levels": levels}))


if __name__ == "__main__":
    main()
