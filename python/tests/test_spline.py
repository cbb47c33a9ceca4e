"""boxforge.Spline: the exact evaluator from Python, checked against what a
box spline must do (partition of unity, reproduction of linear functions by
the symmetric splines, consistent derivatives), against the Rust evaluator it wraps bit for bit, and pickling."""

import os
import pickle
import subprocess

import numpy as np
import pytest

import boxforge
from conftest import smooth_volume
from test_numpy import lattice_points


def linear_samples(lattice, shape, a):
    """a . (z, y, x) + 2 at the lattice points of a box, 0 elsewhere (the embedded layout)."""
    z, y, x = np.meshgrid(*(np.arange(n, dtype=np.float64) for n in shape), indexing="ij")
    v = a[0] * z + a[1] * y + a[2] * x + 2.0
    return np.where(lattice_points(lattice, shape), v, 0).astype(np.float32)


@pytest.mark.parametrize("spec,lattice", [("bcc7", "bcc"), ("fcc6", "fcc"), ("cc_tricubic", "cc")])
def test_symmetric_splines_reproduce_linear_functions_inside(spec, lattice):
    shape, a = (16, 16, 16), (0.25, -0.5, 0.75)
    samples = linear_samples(lattice, shape, a)
    rng = np.random.default_rng(7)
    points = rng.uniform(5.0, 10.0, size=(200, 3))
    s = boxforge.Spline(spec)
    # The filters are normalised to a partition of unity on their lattice.
    values = s.eval(points, samples)
    np.testing.assert_allclose(values, points @ np.array(a) + 2.0, rtol=1e-9, atol=1e-9)
    grads = s.grad(points, samples)
    np.testing.assert_allclose(grads, np.tile(a, (len(points), 1)), atol=1e-9)
    hess = s.hessian(points, samples)
    assert hess.shape == (200, 3, 3) and np.abs(hess).max() < 1e-9


def test_gradient_and_hessian_are_the_values_derivatives():
    rng = np.random.default_rng(3)
    samples = rng.uniform(0, 1, size=(12, 12, 12)).astype(np.float32)
    s = boxforge.Spline("cc_tricubic")
    p = rng.uniform(4.0, 7.0, size=(20, 3))
    h = 1e-5
    for axis in range(3):
        e = np.zeros(3)
        e[axis] = h
        numeric = (s.eval(p + e, samples) - s.eval(p - e, samples)) / (2 * h)
        np.testing.assert_allclose(s.grad(p, samples)[:, axis], numeric, atol=1e-6)
        numeric = (s.grad(p + e, samples) - s.grad(p - e, samples)) / (2 * h)
        np.testing.assert_allclose(s.hessian(p, samples)[:, :, axis], numeric, atol=1e-5)


def test_a_spline_pickles_and_bad_points_are_value_errors():
    s = boxforge.Spline("bcc7")
    t = pickle.loads(pickle.dumps(s))
    samples = linear_samples("bcc", (8, 8, 8), (1, 0, 0))
    assert t.spec == "bcc7" and t.lattice == "bcc"
    assert np.array_equal(t.eval([[3.0, 3.5, 4.0]], samples), s.eval([[3.0, 3.5, 4.0]], samples))
    with pytest.raises(ValueError, match=r"\(N, 3\)"):
        s.eval(np.zeros((4, 2)), samples)
    with pytest.raises(ValueError, match="NaN"):
        s.eval([[np.nan, 1.0, 1.0]], samples)
    with pytest.raises(ValueError, match="3D"):
        boxforge.Spline("z4_cubic").eval([[1.0, 1.0, 1.0]], samples)


def rust_evaluator():
    """The Rust reference, runtime/examples/spline_points.rs (`cargo test --workspace --no-run`
    builds it beside the CLI): `Derivation::eval_f64` at points from a file."""
    exe = os.path.join(os.path.dirname(os.environ.get("BOXFORGE_BIN", "")), "examples", "spline_points")
    if not os.path.exists(exe):
        pytest.fail(f"{exe} is missing: build it (cargo test --workspace --no-run) and run scripts/python/test.sh")
    return exe


@pytest.mark.parametrize("spec", ["bcc7", "fcc6", "cc_tricubic"])
def test_values_and_derivatives_are_the_rust_evaluators_bit_for_bit(spec, tmp_path):
    # A box with no symmetry to hide a wrong axis order; points inside, near and beyond its
    # faces (clamped fetches), and on grid and knot planes (integer and half-integer coordinates).
    samples = smooth_volume((13, 11, 9), seed=5)
    rng = np.random.default_rng(11)
    points = rng.uniform(-2.0, 14.0, size=(400, 3))
    points[:100] = np.round(points[:100] * 2) / 2
    s = boxforge.Spline(spec)
    ours = (s.eval(points, samples), s.grad(points, samples), s.hessian(points, samples))
    # The reference reads (x, y, z) points and x-fastest samples: the layout the Rust side uses.
    samples.tofile(tmp_path / "samples.f32")
    np.ascontiguousarray(points[:, ::-1]).tofile(tmp_path / "points.f64")
    nz, ny, nx = samples.shape
    args = [spec, tmp_path / "samples.f32", nx, ny, nz, tmp_path / "points.f64", tmp_path / "out.f64"]
    r = subprocess.run([rust_evaluator(), *map(str, args)], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    out = np.fromfile(tmp_path / "out.f64", dtype="<f8").reshape(len(points), 13)
    # Derivatives along (x, y, z) back to (z, y, x).
    theirs = (out[:, 0], out[:, 1:4][:, ::-1], out[:, 4:].reshape(-1, 3, 3)[:, ::-1, ::-1])
    for name, a, b in zip(("values", "gradients", "Hessians"), ours, theirs):
        a, b = np.ascontiguousarray(a), np.ascontiguousarray(b)
        differ = np.flatnonzero((a.view(np.uint64) != b.view(np.uint64)).reshape(len(points), -1).any(axis=1))
        assert differ.size == 0, f"{spec} {name} differ at {differ.size} points, first {points[differ[0]]}"
