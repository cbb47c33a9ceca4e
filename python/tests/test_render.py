"""boxforge.render: the image from Python is the image `boxforge render`
writes for the same samples and arguments, byte for byte: isosurfaces and
volume renderings, in core and out of core, from an array and from a
store; a budget below the renderer's estimate is a ValueError with the
runtime's one line."""

import os
import struct
import subprocess
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


def render_cli(cli, tmp_path, raw, shape, *args):
    """The PNG `boxforge render` writes for the raw f32 volume of (z, y, x) `shape`, as an array."""
    out = tmp_path / f"cli-{len(list(tmp_path.iterdir()))}.png"
    cli("render", "--volume", raw, "--raw", f"{shape[2]},{shape[1]},{shape[0]},f32", *args, "--out", out)
    return read_png(out)


@pytest.fixture
def raw_volume(tmp_path):
    volume = smooth_volume((20, 22, 24), seed=9)
    raw = tmp_path / "v.raw"
    volume.tofile(raw)
    return volume, raw


def test_a_volume_rendering_from_python_is_the_clis_image(tmp_path, cli, raw_volume):
    volume, raw = raw_volume
    image = boxforge.render(volume, "bcc7", mode="dvr", size=64)
    assert image.shape == (64, 64, 4) and image.dtype == np.uint8
    assert len(np.unique(image.reshape(-1, 4), axis=0)) > 20, "a shaded volume, not a blank frame"
    want = render_cli(cli, tmp_path, raw, volume.shape, "--filter", "bcc7", "--mode", "dvr", "--size", 64)
    assert np.array_equal(image, want)
    # A preset transfer function, point-sampled, another view and filter.
    image = boxforge.render(volume, "cc_tricubic", mode="dvr", tf="marschner-lobb", preintegrate=False, size=64,
                            azimuth=-40, elevation=10)
    want = render_cli(cli, tmp_path, raw, volume.shape, "--filter", "cc_tricubic", "--mode", "dvr", "--tf",
                      "marschner-lobb", "--no-preintegration", "--size", 64, "--view", "-40,10")
    assert np.array_equal(image, want)
    with pytest.raises(ValueError, match="tf no-such-preset"):
        boxforge.render(volume, "bcc7", mode="dvr", tf="no-such-preset", size=16)
    with pytest.raises(ValueError, match="drop iso"):
        boxforge.render(volume, "bcc7", 12.0, mode="dvr", size=16)
    with pytest.raises(ValueError, match="mode"):
        boxforge.render(volume, "bcc7", 12.0, mode="mip", size=16)


def test_out_of_core_frames_are_the_clis_and_the_in_core_ones(tmp_path, cli, raw_volume):
    volume, raw = raw_volume
    iso = float(np.median(volume))
    # Small enough that the pool holds fewer slots than the volume has bricks: frames take passes.
    paged = boxforge.render(volume, "bcc7", iso, size=64, gpu_budget="320KiB", brick=8)
    want = render_cli(cli, tmp_path, raw, volume.shape, "--filter", "bcc7", "--iso", iso, "--size", 64,
                      "--gpu-budget", "320KiB", "--brick", 8, "--no-bounds-cache")
    assert np.array_equal(paged, want)
    assert len(np.unique(paged.reshape(-1, 4), axis=0)) > 20, "a shaded surface, not a blank frame"
    # The same evaluations at the same points as in core.
    assert np.array_equal(paged, boxforge.render(volume, "bcc7", iso, size=64))
    assert np.array_equal(boxforge.render(volume, "bcc7", iso, size=64, gpu_budget=320 * 1024, brick=8), paged)
    dvr = boxforge.render(volume, "bcc7", mode="dvr", size=64, gpu_budget="640KiB", brick=8)
    want = render_cli(cli, tmp_path, raw, volume.shape, "--filter", "bcc7", "--mode", "dvr", "--size", 64,
                      "--gpu-budget", "640KiB", "--brick", 8, "--no-bounds-cache")
    assert np.array_equal(dvr, want)
    # A store read brick by brick: the CLI's image of the same store.
    store = tmp_path / "bcc.zarr"
    boxforge.to_ome_zarr(volume, store, lattice="bcc", chunk=8, levels=1)
    from_store = boxforge.render(store, "bcc7", iso, size=64, gpu_budget="1MiB", brick=8)
    cli("render", "--filter", "bcc7", "--volume", store, "--iso", iso, "--size", 64, "--gpu-budget", "1MiB",
        "--brick", 8, "--no-bounds-cache", "--out", tmp_path / "s.png")
    assert np.array_equal(from_store, read_png(tmp_path / "s.png"))
    with pytest.raises(ValueError, match="gpu_budget"):
        boxforge.render(volume, "bcc7", iso, size=16, gpu_budget="lots")
    with pytest.raises(ValueError, match="packed"):
        boxforge.render(volume, "bcc7", iso, size=16, gpu_budget="1MiB", layout="packed")
    with pytest.raises(ValueError, match="brick"):
        boxforge.render(volume, "bcc7", iso, size=16, brick=8)


def test_past_the_memory_cap_is_a_value_error_with_the_runtimes_line(tmp_path, cli, raw_volume):
    volume, raw = raw_volume
    iso = float(np.median(volume))
    # The renderer's estimate of what it needs (tables, images, eight slots) past the budget.
    with pytest.raises(ValueError) as e:
        boxforge.render(volume, "bcc7", iso, size=64, gpu_budget="64KiB", brick=8)
    message = str(e.value)
    assert "\n" not in message and "too small" in message and "give at least" in message, message
    r = subprocess.run([os.environ["BOXFORGE_BIN"], "render", "--filter", "bcc7", "--volume", str(raw), "--raw",
                        "24,22,20,f32", "--iso", str(iso), "--size", "64", "--gpu-budget", "64KiB", "--brick", "8",
                        "--no-bounds-cache", "--out", str(tmp_path / "no.png")], capture_output=True, text=True)
    assert r.returncode != 0 and f"error: {message}" in r.stderr, r.stderr
    # The same for DVR, and for a volume past the adapter's texture edge in core.
    with pytest.raises(ValueError, match="too small"):
        boxforge.render(volume, "bcc7", mode="dvr", size=64, gpu_budget="64KiB", brick=8)
    with pytest.raises(ValueError, match="3D texture limit") as e:
        boxforge.render(np.ones((2, 2, 20000), np.float32), "cc_tricubic", 0.5, size=16)
    assert "\n" not in str(e.value)
