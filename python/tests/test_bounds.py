"""boxforge.bounds: the runtime's per-brick bounds of the spline hold every
value of the spline in the brick (the exact evaluator at random points),
lie within the samples the brick and its halo reach, equal the exact
extremes of a linear function (which the splines reproduce), and come in
(z, y, x) order."""

import numpy as np
import pytest

import boxforge
from conftest import smooth_volume
from test_numpy import lattice_points

CASES = [("bcc7", "bcc"), ("fcc6", "fcc"), ("cc_tricubic", "cc")]


def on_lattice(values, lattice):
    return np.where(lattice_points(lattice, values.shape), values, 0).astype(np.float32)


def brick_box(k, brick, shape):
    """The positions brick k spans, clipped to the volume (sample units, z, y, x)."""
    lo = np.array(k) * brick
    hi = np.minimum(lo + brick, np.array(shape) - 1)
    return lo, hi


@pytest.mark.parametrize("spec,lattice", CASES)
def test_the_bounds_hold_every_value_of_the_spline_in_the_brick(spec, lattice):
    shape, brick = (12, 18, 22), 6
    rng = np.random.default_rng(11)
    # Smooth plus noise: the pieces are far from flat, so loose bounds would
    # still hold but wrong ones (another brick's, a missing halo) would not.
    samples = on_lattice(smooth_volume(shape, seed=2) + rng.normal(0, 2, shape), lattice)
    b = boxforge.bounds(samples, spec, brick=brick)
    nk = tuple(-(-n // brick) for n in shape)
    assert b.shape == nk + (2,) and b.dtype == np.float32
    assert np.all(b[..., 0] <= b[..., 1])
    s = boxforge.Spline(spec)
    member = lattice_points(lattice, shape)
    grow = 4  # at least the stencils' reach of these filters
    for k in np.ndindex(nk):
        lo, hi = brick_box(k, brick, shape)
        points = rng.uniform(lo, hi, size=(60, 3))
        # The corners too: where a piece reaches its extremes most often.
        corners = np.array([[(lo, hi)[c][a] for a, c in enumerate(bits)] for bits in np.ndindex(2, 2, 2)], float)
        values = s.eval(np.vstack([points, corners]), samples)
        tol = 1e-4 * (1 + np.abs(values).max())
        assert values.min() >= b[k][0] - tol and values.max() <= b[k][1] + tol, (k, values.min(), values.max(), b[k])
        # And no wider than the samples the brick and its halo reach (the
        # spline's Bernstein coefficients are convex combinations of them).
        # Past the volume the fetches are clamped into it, where they may
        # land off the lattice (on an embedded 0): then every entry counts.
        g0, g1 = np.array(k) * brick - grow, (np.array(k) + 1) * brick + grow + 1
        clipped = np.any(g0 < 0) or np.any(g1 > np.array(shape))
        box = tuple(slice(max(a, 0), min(c, n)) for a, c, n in zip(g0, g1, shape))
        reached = samples[box] if clipped else samples[box][member[box]]
        assert b[k][0] >= reached.min() - tol and b[k][1] <= reached.max() + tol, (k, b[k], reached.min(), reached.max())


@pytest.mark.parametrize("spec,lattice", CASES)
def test_the_bounds_of_a_linear_function_are_its_extremes_over_the_brick(spec, lattice):
    shape, brick, a = (24, 20, 28), 4, np.array([0.5, -0.75, 0.25])
    z, y, x = np.meshgrid(*(np.arange(n, dtype=np.float64) for n in shape), indexing="ij")
    samples = on_lattice(a[0] * z + a[1] * y + a[2] * x + 30.0, lattice)
    b = boxforge.bounds(samples, spec, brick=brick)
    assert b.shape == (6, 5, 7, 2)
    grow, checked = 4, 0
    for k in np.ndindex(b.shape[:3]):
        lo, hi = np.array(k) * brick, (np.array(k) + 1) * brick
        if np.any(lo - grow < 0) or np.any(hi + grow > np.array(shape) - 1):
            continue  # the stencils reach clamped samples: not the linear function there
        want = (30.0 + np.minimum(a * lo, a * hi).sum(), 30.0 + np.maximum(a * lo, a * hi).sum())
        np.testing.assert_allclose(b[k], want, atol=2e-3, err_msg=str(k))
        checked += 1
    assert checked >= 12


def test_bad_bricks_and_samples_are_value_errors():
    samples = on_lattice(smooth_volume((8, 8, 8)), "bcc")
    with pytest.raises(ValueError, match="period 2"):
        boxforge.bounds(samples, "bcc7", brick=3)
    with pytest.raises(ValueError, match="brick 0"):
        boxforge.bounds(samples, "cc_tricubic", brick=0)
    bad = samples.copy()
    bad[2, 2, 2] = np.nan
    with pytest.raises(ValueError, match="finite"):
        boxforge.bounds(bad, "bcc7", brick=4)
    with pytest.raises(ValueError, match="3D"):
        boxforge.bounds(samples, "z4_cubic")
