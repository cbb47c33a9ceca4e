"""boxforge on NumPy arrays: specs, shaders, resampling, prefiltering and
OME-Zarr stores, against closed forms and the CLI."""

import json
import pickle
from fractions import Fraction

import numpy as np
import pytest

import boxforge


def test_inspect_reports_the_derivation_as_the_cli_does(cli):
    r = boxforge.inspect("bcc7")
    assert r["name"] == "bcc7" and r["lattice"] == "bcc" and r["degree"] == 4
    assert r == json.loads(cli("inspect", "bcc7", "--json").stdout)
    # A dict spec and TOML text are the same filter as the catalog's.
    spec = {"name": "mine", "lattice": "bcc",
            "directions": [[1, 1, 1], [-1, 1, 1], [1, -1, 1], [1, 1, -1], [2, 0, 0], [0, 2, 0], [0, 0, 2]]}
    mine = boxforge.inspect(spec)
    assert mine["name"] == "mine"
    assert mine["prefilter"] == r["prefilter"] and mine["reference_pieces"] == r["reference_pieces"]
    with pytest.raises(ValueError, match="no_such_filter"):
        boxforge.inspect("no_such_filter")


def test_shader_is_wgsl_with_its_bindings():
    source, bindings = boxforge.shader("cc_trilinear")
    assert "fn cc_trilinear_eval" in source
    assert bindings and all({"group", "binding", "name", "kind"} <= set(b) for b in bindings)
    assert any(b["kind"].startswith("texture_3d") for b in bindings)
    packed, _ = boxforge.shader("bcc7", layout="packed")
    assert "fn bcc7_eval" in packed
    with pytest.raises(ValueError, match="layout"):
        boxforge.shader("bcc7", layout="sideways")
    with pytest.raises(ValueError, match="generate --target"):
        boxforge.shader("bcc7", target="glsl")


def lattice_points(name, shape):
    z, y, x = np.meshgrid(*(np.arange(n) for n in shape), indexing="ij")
    if name == "bcc":
        return (x % 2 == y % 2) & (y % 2 == z % 2)
    if name == "fcc":
        return (x + y + z) % 2 == 0
    return np.ones(shape, bool)


@pytest.mark.parametrize("lattice", ["bcc", "fcc"])
def test_resampling_reproduces_a_linear_function_at_the_scaled_lattice_points(lattice):
    shape = (9, 8, 7)
    z, y, x = np.meshgrid(*(np.arange(n, dtype=np.float64) for n in shape), indexing="ij")
    vol = (1 + 0.5 * x - 0.25 * y + 2 * z).astype(np.float32)
    out = boxforge.resample(vol, lattice)
    (lz, ly, lx), s = boxforge.matched_lattice(lattice, shape)
    assert out.shape == (lz, ly, lx) and out.dtype == np.float32
    zz, yy, xx = np.meshgrid(*(np.arange(n, dtype=np.float64) for n in out.shape), indexing="ij")
    want = 1 + 0.5 * np.minimum(xx * s, 6) - 0.25 * np.minimum(yy * s, 7) + 2 * np.minimum(zz * s, 8)
    on = lattice_points(lattice, out.shape)
    np.testing.assert_allclose(out[on], want[on], atol=1e-4)
    assert not out[~on].any(), "zero off the lattice"


def numpy_prefilter(samples, taps, lattice):
    """c_j = sum_k q_k f(j - k) at lattice points, f read clamped into the box (independent of the Rust)."""
    n = samples.shape
    pad = max(abs(c) for t in taps for c in t[0])
    padded = np.pad(samples.astype(np.float64), pad, mode="edge")
    out = np.zeros(n, np.float64)
    for (kx, ky, kz), w in taps:
        out += w * padded[pad - kz:pad - kz + n[0], pad - ky:pad - ky + n[1], pad - kx:pad - kx + n[2]]
    return np.where(lattice_points(lattice, n), out, 0)


@pytest.mark.parametrize("spec,lattice", [("bcc7", "bcc"), ("fcc6", "fcc"), ("cc_tricubic", "cc")])
def test_prefilter_is_the_reported_taps_convolution(volume, spec, lattice):
    samples = boxforge.resample(volume, lattice) if lattice != "cc" else volume
    taps = [(t["offset"], float(Fraction(t["w"]))) for t in boxforge.inspect(spec)["prefilter"]]
    got = boxforge.prefilter(samples, spec)
    np.testing.assert_allclose(got, numpy_prefilter(samples, taps, lattice), rtol=1e-5, atol=1e-4)


def test_nan_samples_are_refused_naming_the_first_not_spread(volume, tmp_path):
    bad = volume.copy()
    bad[3, 4, 5] = np.nan
    bad[6, 1, 1] = np.inf
    for call in (lambda: boxforge.prefilter(bad, "cc_tricubic"), lambda: boxforge.resample(bad, "bcc"),
                 lambda: boxforge.to_ome_zarr(bad, tmp_path / "nan.zarr"),
                 lambda: boxforge.render(bad, "cc_trilinear", iso=0.5, size=8)):
        with pytest.raises(ValueError, match=r"\(z, y, x\) = \(3, 4, 5\) is NaN"):
            call()


def test_bad_arrays_are_a_value_error_naming_the_problem(volume):
    with pytest.raises(ValueError, match="3D array"):
        boxforge.prefilter(volume[0], "bcc7")
    with pytest.raises(ValueError, match="real samples"):
        boxforge.resample(volume.astype(np.complex64), "bcc")
    with pytest.raises(ValueError, match="lattice"):
        boxforge.resample(volume, "hexagonal")
    with pytest.raises(ValueError, match="3D filter"):
        boxforge.prefilter(volume, "z4_cubic")
    # A transposed (non-contiguous) view is taken as the array it is.
    t = np.transpose(volume, (2, 1, 0))
    assert np.array_equal(boxforge.resample(t, "bcc"), boxforge.resample(np.ascontiguousarray(t), "bcc"))


def test_stores_round_trip_and_equal_the_clis(tmp_path, volume, cli):
    store = tmp_path / "bcc.zarr"
    levels = boxforge.to_ome_zarr(volume, store, prefilter="bcc7", chunk=4, levels=2, spacing=(2.0, 1.0, 0.5),
                                  unit="millimeter")
    s = boxforge.open(store)
    assert (s.lattice, s.prefilter, s.unit) == ("bcc", "bcc7", "millimeter")
    assert s.samples.shape == levels[0]
    assert np.array_equal(s.samples, boxforge.prefilter(boxforge.resample(volume, "bcc"), "bcc7"))
    # The CLI writes the same samples from the same volume as a raw file.
    raw = tmp_path / "v.raw"
    volume.tofile(raw)
    z, y, x = volume.shape
    cli("convert", raw, tmp_path / "cli.zarr", "--raw", f"{x},{y},{z},f32", "--lattice", "bcc", "--prefilter", "bcc7",
        "--chunk", "5", "--levels", "2")
    for k in range(2):
        assert np.array_equal(boxforge.open(tmp_path / "cli.zarr", level=k).samples, boxforge.open(store, level=k).samples)
    plain = boxforge.open(cli("convert", raw, tmp_path / "cc.zarr", "--raw", f"{x},{y},{z},f32") and tmp_path / "cc.zarr")
    assert plain.lattice == "cc" and plain.prefilter is None and np.array_equal(plain.samples, volume)
    with pytest.raises(ValueError, match="exists"):
        boxforge.to_ome_zarr(volume, store)
    with pytest.raises(ValueError, match="float32"):
        boxforge.to_ome_zarr(volume, tmp_path / "u8.zarr", prefilter="bcc7", dtype="uint8")
    assert pickle.loads(pickle.dumps(s)).lattice == "bcc"
