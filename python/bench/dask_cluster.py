"""boxforge.dask on a Dask cluster of separate processes: the store
`boxforge convert --lattice bcc --prefilter bcc7` writes, made by
`boxforge.dask.to_ome_zarr` on a `dask scheduler` and `dask worker`
processes on 127.0.0.1, checked byte for byte against the CLI's store,
timed, and each worker's peak memory measured.

    python python/bench/dask_cluster.py [--sizes 256,512] [--chunks 32,64,96]
        [--workers 1,2] [--out DIR] [--cli target/release/boxforge]

The volume (a closed-form smooth signal) is written once as a raw float32
file, which the workers read chunk by chunk with pread (as `da.from_zarr`
reads a store: nothing of the volume in the task graph, no memory map), so
a worker's memory holds chunks, never the volume. Each worker's resident
set is sampled every 20 ms from outside (psutil on its process): the peak
above its idle size before the run. Prints one Markdown table row per run
and writes the rows as JSON to OUT/dask_cluster.json.
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import socket
import subprocess
import sys
import threading
import time

import dask
import dask.array as da
import numpy as np
import psutil

import boxforge.dask as bd


def signal_block(block_info=None):
    """The smooth test signal on one chunk: the same float32 values
    wherever the chunk boundaries fall (an elementwise formula of the
    global coordinates)."""
    info = block_info[None]
    (z0, z1), (y0, y1), (x0, x1) = info["array-location"]
    n = info["shape"][0]
    z, y, x = np.meshgrid(*(np.arange(a, b, dtype=np.float32) / np.float32(n) for a, b in ((z0, z1), (y0, y1), (x0, x1))),
                          indexing="ij")
    r = np.sqrt((x - 0.5) ** 2 + (y - 0.5) ** 2, dtype=np.float32)
    v = (np.float32(0.5) + np.float32(0.5) * np.cos(np.float32(2 * np.pi * 6) * r) * np.sin(np.float32(3.0) * z)
         + np.float32(0.25) * np.sin(np.float32(7.0) * x + np.float32(5.0) * y))
    return v.astype(np.float32)


def write_raw(n: int, path: str) -> None:
    """The signal as a raw float32 file (z, y, x), written slab by slab."""
    v = da.map_blocks(signal_block, dtype=np.float32, chunks=da.core.normalize_chunks(64, (n, n, n)),
                      meta=np.empty((0, 0, 0), np.float32))
    with open(path, "wb") as f:
        for z in range(0, n, 64):
            f.write(v[z:z + 64].compute(scheduler="sync").tobytes())


def read_block(path: str, n: int, block_info=None) -> np.ndarray:
    """A chunk of the raw file, read with pread (no memory map: a worker's
    resident set holds the chunk, not the pages of the file it touched)."""
    (z0, z1), (y0, y1), (x0, x1) = block_info[None]["array-location"]
    out = np.empty((z1 - z0, y1 - y0, x1 - x0), np.float32)
    fd = os.open(path, os.O_RDONLY)
    try:
        for z in range(z0, z1):
            rows = os.pread(fd, (y1 - y0) * n * 4, ((z * n) + y0) * n * 4)
            out[z - z0] = np.frombuffer(rows, np.float32).reshape(y1 - y0, n)[:, x0:x1]
    finally:
        os.close(fd)
    return out


def volume(path: str, n: int, chunk: int) -> da.Array:
    """The raw file as a dask array read chunk by chunk by the workers (as
    `da.from_zarr` reads a store): nothing of the volume in the graph."""
    return da.map_blocks(read_block, path, n, dtype=np.float32, chunks=da.core.normalize_chunks(chunk, (n, n, n)),
                         meta=np.empty((0, 0, 0), np.float32))


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


class Cluster:
    """A scheduler and `workers` single-threaded worker processes (no nanny:
    the worker is the process whose memory is sampled)."""

    def __init__(self, workers: int, scratch: str):
        self.port = free_port()
        self.address = f"tcp://127.0.0.1:{self.port}"
        dask_bin = os.path.join(os.path.dirname(sys.executable), "dask")
        env = dict(os.environ, DASK_DISTRIBUTED__WORKER__DAEMON="False")
        quiet = dict(stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, env=env)
        self.procs = [subprocess.Popen([dask_bin, "scheduler", "--host", "127.0.0.1", "--port", str(self.port),
                                        "--no-dashboard"], **quiet)]
        self.workers = []
        for i in range(workers):
            p = subprocess.Popen([dask_bin, "worker", self.address, "--nthreads", "1", "--no-nanny",
                                  "--no-dashboard", "--memory-limit", "0", "--name", f"w{i}",
                                  "--local-directory", os.path.join(scratch, f"w{i}")], **quiet)
            self.procs.append(p)
            self.workers.append(p)
        from distributed import Client

        self.client = Client(self.address, timeout=60)
        self.client.wait_for_workers(workers, timeout=120)

    def close(self):
        try:
            self.client.shutdown()
            self.client.close()
        finally:
            for p in self.procs:
                p.terminate()
            for p in self.procs:
                try:
                    p.wait(timeout=20)
                except subprocess.TimeoutExpired:
                    p.kill()


class PeakRss:
    """The largest resident set of each process, sampled every 20 ms."""

    def __init__(self, pids):
        self.procs = [psutil.Process(p) for p in pids]
        self.idle = [p.memory_info().rss for p in self.procs]
        self.peak = list(self.idle)
        self.stop = threading.Event()
        self.thread = threading.Thread(target=self.run, daemon=True)
        self.thread.start()

    def run(self):
        while not self.stop.is_set():
            for i, p in enumerate(self.procs):
                try:
                    self.peak[i] = max(self.peak[i], p.memory_info().rss)
                except psutil.Error:
                    pass
            time.sleep(0.02)

    def done(self):
        self.stop.set()
        self.thread.join()
        return [p - i for p, i in zip(self.peak, self.idle)]


def same_store(a: str, b: str) -> bool:
    def files(root):
        out = {}
        for d, _, fs in os.walk(root):
            for f in fs:
                with open(os.path.join(d, f), "rb") as fh:
                    out[os.path.relpath(os.path.join(d, f), root)] = fh.read()
        return out

    return files(a) == files(b)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--sizes", default="256,512")
    ap.add_argument("--chunks", default="64,96,128", help="store chunk edges (each task's block is twice that on BCC)")
    ap.add_argument("--workers", default="2")
    ap.add_argument("--scaling", default="512:64", help="SIZE:CHUNK run with 1 and 2 workers ('' to skip)")
    ap.add_argument("--check", default="512:64", help="SIZE:CHUNK compared byte for byte with the CLI ('' to skip)")
    ap.add_argument("--cli", default="target/release/boxforge")
    ap.add_argument("--out", default="target/bench-dask")
    a = ap.parse_args()
    os.makedirs(a.out, exist_ok=True)
    runs = [(n, c, w) for n in map(int, a.sizes.split(",")) for c in map(int, a.chunks.split(","))
            for w in map(int, a.workers.split(","))]
    if a.scaling:
        n, c = map(int, a.scaling.split(":"))
        runs += [(n, c, w) for w in (1, 2) if (n, c, w) not in runs]
    rows = []
    print("| volume | store chunk | workers | wall (s) | tasks | peak RSS above idle per worker (MiB) | = CLI |")
    print("|---|---|---|---|---|---|---|")
    for n, c, w in runs:
        store = os.path.join(a.out, f"dask-{n}-{c}-{w}.zarr")
        shutil.rmtree(store, ignore_errors=True)
        raw = os.path.join(a.out, f"v{n}.raw")
        if not os.path.exists(raw):
            write_raw(n, raw)
        cluster = Cluster(w, a.out)
        try:
            x = volume(os.path.abspath(raw), n, 2 * c)
            rss = PeakRss([p.pid for p in cluster.workers])
            t = time.perf_counter()
            plan = bd._boxforge.StorePlan(os.path.abspath(store), (n, n, n), prefilter="bcc7", chunk=c)
            stages = bd.store_stages(x, plan)
            # The tasks the scheduler runs: each stage's graph after dask's optimisation (culled, fused).
            tasks = sum(len(dict(dask.optimize(*stage)[0].__dask_graph__())) if len(stage) == 1 else len(stage)
                        for stage in stages)
            levels = bd.to_ome_zarr(x, store, "bcc7", chunk=c)
            wall = time.perf_counter() - t
            peaks = rss.done()
        finally:
            cluster.close()
        same = ""
        if a.check and (n, c) == tuple(map(int, a.check.split(":"))) and a.cli:
            cli_store = os.path.join(a.out, f"cli-{n}-{c}.zarr")
            if not os.path.exists(cli_store):
                t0 = time.perf_counter()
                subprocess.run([a.cli, "convert", raw, cli_store, "--raw", f"{n},{n},{n},f32", "--lattice", "bcc",
                                "--prefilter", "bcc7", "--chunk", str(c)], check=True, stdout=subprocess.DEVNULL,
                               stderr=subprocess.DEVNULL)
                rows.append(dict(cli=True, volume=n, chunk=c, wall=time.perf_counter() - t0))
                print(f"| {n}^3 | {c} | (CLI convert, one process, all cores) | {rows[-1]['wall']:.1f} | - | - | - |")
            same = "yes" if same_store(store, cli_store) else "NO"
        row = dict(volume=n, chunk=c, workers=w, wall=wall, tasks=tasks,
                   peak_mib=[p / 2**20 for p in peaks], same_as_cli=same)
        rows.append(row)
        print(f"| {n}^3 | {c} | {w} | {wall:.1f} | {tasks} | "
              f"{', '.join(f'{p:.0f}' for p in row['peak_mib'])} | {same or '-'} |", flush=True)
        shutil.rmtree(store, ignore_errors=True)
    with open(os.path.join(a.out, "dask_cluster.json"), "w") as f:
        json.dump(rows, f, indent=1)


if __name__ == "__main__":
    main()
