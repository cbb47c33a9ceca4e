"""boxforge.Spline: the exact evaluator from Python, checked against what a
box spline must do (partition of unity, reproduction of linear functions by
the symmetric splines, consistent derivatives), and pickling."""

import pickle

import numpy as np
import pytest

import boxforge
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
