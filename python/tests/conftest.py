"""Shared fixtures: the CLI the package is checked against, and test volumes."""

import os
import subprocess

import numpy as np
import pytest


@pytest.fixture(scope="session")
def cli():
    """Runs the boxforge CLI (BOXFORGE_BIN, set by scripts/python/test.sh); returns its result."""
    exe = os.environ.get("BOXFORGE_BIN")
    if not exe or not os.path.exists(exe):
        pytest.fail("BOXFORGE_BIN is not set to the boxforge binary: run scripts/python/test.sh")

    def run(*args):
        r = subprocess.run([exe, *map(str, args)], capture_output=True, text=True)
        assert r.returncode == 0, f"boxforge {' '.join(map(str, args))}: {r.stderr}"
        return r

    return run


def smooth_volume(shape, seed=1):
    """A smooth volume with no symmetry a wrong axis order could hide behind (float32, z, y, x)."""
    z, y, x = np.meshgrid(*(np.arange(n, dtype=np.float64) for n in shape), indexing="ij")
    rng = np.random.default_rng(seed)
    a = rng.uniform(0.1, 0.4, size=3)
    v = 10 + 0.7 * x - 0.3 * y + 0.2 * z + 3 * np.sin(a[0] * x + a[1] * y * 0.5) * np.cos(a[2] * z)
    return v.astype(np.float32)


@pytest.fixture
def volume():
    return smooth_volume((13, 11, 9))
