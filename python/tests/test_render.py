"""boxforge.render: the isosurface image from Python is the image `boxforge
render` writes for the same samples, byte for byte, from an array and from
a store."""

import struct
import zlib

import numpy as np
import pytest

import boxforge
from conftest import smooth_volume


def read_png(path):
    """The RGBA8 pixels of a non-interlaced 8-bit RGBA PNG, as an (h, w, 4) array."""
    data = open(path, "rb").read()
    assert data[:8] == b"\x89PNG\r\n\x1a\n"
    pos, idat, width = 8, b"", None
    while pos < len(data):
        n, kind = struct.unpack(">I4s", data[pos:pos + 8])
        body = data[pos + 8:pos + 8 + n]
        if kind == b"IHDR":
            width, height, depth, colour, _, _, interlace = struct.unpack(">IIBBBBB", body)
            assert (depth, colour, interlace) == (8, 6, 0), "RGBA8, not interlaced"
        elif kind == b"IDAT":
            idat += body
        pos += 12 + n
    raw = zlib.decompress(idat)
    stride, bpp = width * 4, 4
    out = np.zeros((height, stride), np.uint8)
    prev = np.zeros(stride, np.int32)
    for y in range(height):
        f, line = raw[y * (stride + 1)], np.frombuffer(raw, np.uint8, stride, y * (stride + 1) + 1).astype(np.int32)
        cur = np.zeros(stride, np.int32)
        for x in range(stride):
            a = cur[x - bpp] if x >= bpp else 0
            b, c = prev[x], (prev[x - bpp] if x >= bpp else 0)
            if f == 0:
                p = 0
            elif f == 1:
                p = a
            elif f == 2:
                p = b
            elif f == 3:
                p = (a + b) // 2
            else:
                pa, pb, pc = abs(b - c), abs(a - c), abs(a + b - 2 * c)
                p = a if pa <= pb and pa <= pc else (b if pb <= pc else c)
            cur[x] = (line[x] + p) & 255
        out[y], prev = cur, cur
    return out.reshape(height, width, 4)


def test_an_isosurface_from_python_is_the_clis_image(tmp_path, cli):
    volume = smooth_volume((20, 22, 24), seed=5)
    iso = float(np.median(volume))
    image = boxforge.render(volume, "bcc7", iso, size=48)
    assert image.shape == (48, 48, 4) and image.dtype == np.uint8
    assert len(np.unique(image.reshape(-1, 4), axis=0)) > 20, "a shaded surface, not a blank frame"
    raw = tmp_path / "v.raw"
    volume.tofile(raw)
    out = tmp_path / "cli.png"
    cli("render", "--filter", "bcc7", "--volume", raw, "--raw", "24,22,20,f32", "--iso", iso, "--size", 48,
        "--out", out)
    assert np.array_equal(image, read_png(out))
    # The same from a store of bcc7's coefficients: the samples drawn as they are.
    store = tmp_path / "bcc.zarr"
    boxforge.to_ome_zarr(volume, store, lattice="bcc", chunk=8, levels=1)
    from_store = boxforge.render(store, "bcc7", iso, size=48)
    cli("render", "--filter", "bcc7", "--volume", store, "--iso", iso, "--size", 48, "--out", tmp_path / "s.png")
    assert np.array_equal(from_store, read_png(tmp_path / "s.png"))
    assert np.array_equal(boxforge.render(volume, "bcc7", iso, size=48, resample=True), from_store)
    with pytest.raises(ValueError, match="on the lattice already"):
        boxforge.render(store, "bcc7", iso, resample=True)
    with pytest.raises(ValueError, match="size"):
        boxforge.render(volume, "bcc7", iso, size=0)
