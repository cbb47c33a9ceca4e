"""boxforge.dask: the passes chunk by chunk with their halos equal the
whole-volume passes bit for bit, seams included, on odd chunkings; and on a
Dask cluster of separate processes (a `dask scheduler` and two `dask worker`
processes on 127.0.0.1) they equal what `boxforge convert --lattice bcc
--prefilter bcc7` stores."""

import os
import socket
import subprocess
import sys
import pickle
import time

import dask
import dask.array as da
import numpy as np
import pytest

import boxforge
import boxforge.dask as bd
from conftest import smooth_volume


@pytest.mark.parametrize("chunks", [(5, 4, 3), (13, 1, 7), (4, 3, 5)])
def test_prefilter_and_resample_by_chunks_equal_the_whole(volume, chunks):
    x = da.from_array(volume, chunks=chunks)
    for lattice, spec in [("bcc", "bcc7"), ("fcc", "fcc6")]:
        whole = boxforge.resample(volume, lattice)
        lazy = bd.resample(x, lattice)
        assert lazy.shape == whole.shape
        got = lazy.compute(scheduler="threads")
        assert np.array_equal(got, whole), f"{lattice} resampling, chunks {chunks}"
        pre = bd.prefilter(da.from_array(whole, chunks=chunks), spec).compute(scheduler="threads")
        assert np.array_equal(pre, boxforge.prefilter(whole, spec)), f"{spec} prefilter, chunks {chunks}"
    # The grid is kept: the cc prefilter by map_overlap.
    cc = bd.prefilter(x, "cc_tricubic").compute(scheduler="threads")
    assert np.array_equal(cc, boxforge.prefilter(volume, "cc_tricubic"))


@pytest.mark.parametrize("spec, lattice", [("bcc7", "bcc"), ("cc_tricubic", None)])
def test_bounds_by_odd_chunks_equal_the_whole_volumes(volume, spec, lattice):
    samples = boxforge.resample(volume, lattice) if lattice else volume
    lazy = bd.bounds(da.from_array(samples, chunks=(5, 11, 7)), spec, brick=4)
    assert lazy.shape == boxforge.bounds(samples, spec, brick=4).shape
    assert np.array_equal(lazy.compute(scheduler="threads"), boxforge.bounds(samples, spec, brick=4)), spec


def test_a_chunk_thinner_than_the_halo_is_merged_not_wrong(volume):
    x = da.from_array(volume, chunks=((1,) * volume.shape[0], 11, 9))
    assert np.array_equal(bd.prefilter(x, "cc_tricubic").compute(scheduler="threads"),
                          boxforge.prefilter(volume, "cc_tricubic"))


def free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@pytest.fixture
def cluster(tmp_path):
    """A scheduler and two single-threaded workers, each its own process."""
    port = free_port()
    bin_dir = os.path.dirname(sys.executable)
    address = f"tcp://127.0.0.1:{port}"
    env = dict(os.environ, DASK_DISTRIBUTED__WORKER__DAEMON="False")
    procs = [subprocess.Popen([os.path.join(bin_dir, "dask"), "scheduler", "--host", "127.0.0.1", "--port", str(port),
                               "--no-dashboard"], env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)]
    for i in range(2):
        procs.append(subprocess.Popen([os.path.join(bin_dir, "dask"), "worker", address, "--nthreads", "1",
                                       "--nworkers", "1", "--no-dashboard", "--name", f"w{i}",
                                       "--local-directory", str(tmp_path / f"w{i}")],
                                      env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL))
    from distributed import Client

    client = None
    try:
        client = Client(address, timeout=60)
        client.wait_for_workers(2, timeout=120)
        yield client
    finally:
        if client is not None:
            client.shutdown()  # stops the scheduler and the workers
            client.close()
        for p in procs:
            p.terminate()
        for p in procs:
            try:
                p.wait(timeout=20)
            except subprocess.TimeoutExpired:
                p.kill()


def store_files(path):
    """Every file of a store (path relative to it) and its bytes."""
    out = {}
    for d, _, files in os.walk(path):
        for f in files:
            full = os.path.join(d, f)
            with open(full, "rb") as fh:
                out[os.path.relpath(full, path)] = fh.read()
    return out


def assert_same_store(got, want):
    got, want = store_files(got), store_files(want)
    assert sorted(got) == sorted(want), "the stores hold different files"
    differ = [f for f in want if got[f] != want[f]]
    assert not differ, f"files differ from convert's: {differ[:5]}"


def test_two_worker_processes_write_what_convert_writes(cluster, tmp_path, cli):
    volume = smooth_volume((64, 64, 64), seed=3)
    x = da.from_array(volume, chunks=(13, 17, 11))
    levels = bd.to_ome_zarr(x, tmp_path / "dask.zarr", "bcc7", chunk=16)  # the client is the default scheduler
    # Both workers did some of the work (tasks spread over processes, not threads of one).
    processed = cluster.run(lambda dask_worker: len(dask_worker.state.log))
    assert len(processed) == 2 and all(n > 0 for n in processed.values()), processed
    raw = tmp_path / "v.raw"
    volume.tofile(raw)
    cli("convert", raw, tmp_path / "cli.zarr", "--raw", "64,64,64,f32", "--lattice", "bcc", "--prefilter", "bcc7",
        "--chunk", "16")
    assert len(levels) == 3
    # The same bytes: every level's chunks (prefiltered BCC samples, seams
    # included) and the metadata.
    assert_same_store(tmp_path / "dask.zarr", tmp_path / "cli.zarr")
    stored = boxforge.open(tmp_path / "dask.zarr", level=1)
    assert (stored.lattice, stored.prefilter, stored.samples.shape) == ("bcc", "bcc7", levels[1])


@pytest.mark.parametrize("options, flags", [
    (dict(dtype="uint8", reduction="binomial"), ["--dtype", "u8", "--reduction", "binomial"]),
    (dict(lattice="fcc", shard=16), ["--lattice", "fcc", "--shard", "16"]),
    (dict(spec="cc_tricubic", levels=2, reduction="tent"), ["--lattice", "cc", "--prefilter", "cc_tricubic",
                                                             "--levels", "2", "--reduction", "tent"]),
])
def test_stores_from_odd_chunks_are_converts_bytes(tmp_path, cli, options, flags):
    volume = smooth_volume((21, 30, 19), seed=5) * 300 - 20  # integer types clamp and round
    x = da.from_array(volume, chunks=(5, 7, 4))
    with dask.config.set(scheduler="threads"):
        bd.to_ome_zarr(x, tmp_path / "dask.zarr", chunk=8, **options)
    raw = tmp_path / "v.raw"
    volume.astype(np.float32).tofile(raw)
    cli("convert", raw, tmp_path / "cli.zarr", "--raw", "19,30,21,f32", "--chunk", "8", *flags)
    assert_same_store(tmp_path / "dask.zarr", tmp_path / "cli.zarr")


def test_reduce_by_odd_chunks_is_the_level_convert_stores(tmp_path, cli):
    volume = smooth_volume((21, 30, 19), seed=7)
    raw = tmp_path / "v.raw"
    volume.tofile(raw)
    for reduction in ("box", "binomial"):
        store = tmp_path / f"{reduction}.zarr"
        cli("convert", raw, store, "--raw", "19,30,21,f32", "--chunk", "8", "--levels", "2", "--reduction", reduction)
        level1 = boxforge.open(store, level=1).samples
        got = bd.reduce(da.from_array(volume, chunks=(5, 7, 4)), reduction, chunks=(3, 4, 5))
        assert np.array_equal(got.compute(scheduler="threads"), level1), reduction


def test_a_store_plan_pickles_and_refuses_blocks_that_are_not_write_units(tmp_path):
    plan = boxforge._boxforge.StorePlan(str(tmp_path / "s.zarr"), (20, 20, 20), prefilter="bcc7", chunk=8)
    again = pickle.loads(pickle.dumps(plan))
    assert (again.levels, again.block, again.lattice) == (plan.levels, plan.block, "bcc")
    plan.create()
    with pytest.raises(ValueError, match="not a write unit"):
        plan.write(0, np.zeros((16, 16, 16), np.float32), (1, 0, 0))
    with pytest.raises(ValueError, match="exists"):
        bd.to_ome_zarr(np.zeros((8, 8, 8), np.float32), tmp_path / "s.zarr")
    with pytest.raises(ValueError, match="lattice"):
        bd.to_ome_zarr(np.zeros((8, 8, 8), np.float32), tmp_path / "t.zarr", "fcc6", lattice="bcc")
