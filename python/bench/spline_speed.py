"""Speed per point of ``boxforge.Spline.eval`` against the Rust evaluator it wraps.

For each spec: the same N points (uniform inside a 64^3 volume of random float32 samples) are
evaluated by ``Spline.eval`` (numpy arrays prepared outside the timer; every core, the GIL
released) and by runtime/examples/spline_points.rs (``Derivation::eval_f64`` looped over the
points on one thread, and over every core with ``boxforge_runtime::par::par_map``). Each side
is the best of REPS runs, in rounds that alternate the two sides (so that other load on the
machine hits both alike); the ratios come from this one run. Wall time per point, and CPU time
per point (every thread of the process: what other load on the machine disturbs least).

    cargo test --workspace --no-run        # the extension and the example
    scripts/python/test.sh -k spline       # once: makes the venv and puts boxforge on its path
    target/python-venv/bin/python python/bench/spline_speed.py [--points N] [--reps R]
"""

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time

import numpy as np

import boxforge

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
SPECS = ("bcc7", "fcc6", "cc_tricubic")


def best(f, reps):
    """The least wall and the least CPU seconds (every thread of the process) of REPS runs of f."""
    wall = cpu = float("inf")
    for _ in range(reps):
        t, c = time.perf_counter(), time.process_time()
        f()
        wall, cpu = min(wall, time.perf_counter() - t), min(cpu, time.process_time() - c)
    return wall, cpu


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--points", type=int, default=100_000)
    ap.add_argument("--reps", type=int, default=3, help="runs per side per round (best counts)")
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--rust", default=os.path.join(ROOT, "target", "debug", "examples", "spline_points"))
    ap.add_argument("--specs", nargs="*", default=list(SPECS))
    a = ap.parse_args()
    if not os.path.exists(a.rust):
        sys.exit(f"{a.rust} is missing: cargo test --workspace --no-run builds it")
    rng = np.random.default_rng(1)
    samples = rng.uniform(0.0, 1.0, size=(64, 64, 64)).astype(np.float32)
    points = rng.uniform(2.0, 61.0, size=(a.points, 3))
    ns = 1e9 / a.points
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        samples.tofile(os.path.join(tmp, "samples.f32"))
        np.ascontiguousarray(points[:, ::-1]).tofile(os.path.join(tmp, "points.f64"))
        for spec in a.specs:
            s = boxforge.Spline(spec)
            s.eval(points[:10], samples)  # derives the filter (once per process)
            cmd = [a.rust, spec, os.path.join(tmp, "samples.f32"), "64", "64", "64"]
            cmd += [os.path.join(tmp, "points.f64"), "--time", str(a.reps)]
            rust, py = {}, (float("inf"), float("inf"))
            for _ in range(a.rounds):
                r = json.loads(subprocess.run(cmd, capture_output=True, text=True, check=True).stdout)
                rust = {k: min(v, rust.get(k, v)) for k, v in r.items()}
                py = tuple(map(min, py, best(lambda: s.eval(points, samples), a.reps)))
            rows.append((spec, rust, py[0] * ns, py[1] * ns))
    print(f"{a.points} points, best of {a.rounds} x {a.reps} runs per side, {os.cpu_count()} cores; per point:\n")
    print(
        "| spec | eval_f64, one thread | eval_f64, par_map | Spline.eval | Spline.eval / par_map "
        "| Spline.eval / one thread | CPU: par_map | CPU: Spline.eval | CPU: Spline.eval / par_map |"
    )
    print("|---|---:|---:|---:|---:|---:|---:|---:|---:|")
    for spec, r, wall, cpu in rows:
        one, par, par_cpu = r["one_thread_ns"], r["par_map_ns"], r["par_map_cpu_ns"]
        print(
            f"| {spec} | {one:.0f} ns | {par:.0f} ns | {wall:.0f} ns | {wall / par:.2f} | {wall / one:.2f} "
            f"| {par_cpu:.0f} ns | {cpu:.0f} ns | {cpu / par_cpu:.2f} |"
        )


if __name__ == "__main__":
    main()
