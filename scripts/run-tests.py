#!/usr/bin/env python3
"""Runs the workspace's test binaries two at a time, longest first.

`cargo test` runs its test binaries one after another, each with as many
test threads as cores; the runtime's integration binary alone is most of the
suite's time and leaves cores idle while it waits on lavapipe and on the
processes its CLI tests start. Here every binary `cargo test --no-run` built
(the arguments are cargo's package selection, e.g. `--workspace --exclude X`)
runs in its package's folder as cargo would run it, two binaries at a time,
each binary's output printed whole when it ends; then the doc tests run.
Exit status 1 when any test failed, after every binary has run.
"""
import json
import os
import subprocess
import sys
import tempfile
import time
from concurrent.futures import ThreadPoolExecutor

PARALLEL_BINARIES = 2


def built_tests(selection):
    """(package name, target name, executable, package folder) of each test binary."""
    cmd = ["cargo", "test", "--locked", "--no-run", "--message-format=json-render-diagnostics", *selection]
    out = subprocess.run(cmd, stdout=subprocess.PIPE, check=True, text=True).stdout
    found = []
    for line in out.splitlines():
        msg = json.loads(line)
        if msg.get("reason") == "compiler-artifact" and msg.get("executable") and msg["profile"]["test"]:
            folder = os.path.dirname(msg["manifest_path"])
            name = msg["target"]["name"]
            found.append((os.path.basename(folder), name, msg["executable"], folder))
    return found


def run(binary):
    package, target, exe, folder = binary
    t0 = time.monotonic()
    with tempfile.TemporaryFile(mode="w+") as log:
        code = subprocess.run([exe], cwd=folder, stdout=log, stderr=subprocess.STDOUT).returncode
        log.seek(0)
        text = log.read()
    return binary, code, text, time.monotonic() - t0


def main():
    selection = sys.argv[1:]
    binaries = built_tests(selection)
    # Integration binaries (`it`) first: they are the long ones.
    binaries.sort(key=lambda b: (b[1] != "it", b[0], b[1]))
    failed = []
    with ThreadPoolExecutor(PARALLEL_BINARIES) as pool:
        for (package, target, exe, _), code, text, secs in pool.map(run, binaries):
            sys.stdout.write(f"     Running {package}/{target} ({os.path.basename(exe)})\n{text}")
            sys.stdout.write(f"     {package}/{target}: {secs:.0f} s, {'ok' if code == 0 else 'FAILED'}\n")
            sys.stdout.flush()
            if code != 0:
                failed.append(f"{package}/{target}")
    t0 = time.monotonic()
    doc = subprocess.run(["cargo", "test", "--locked", "--doc", *selection]).returncode
    print(f"     doc tests: {time.monotonic() - t0:.0f} s, {'ok' if doc == 0 else 'FAILED'}")
    if doc != 0:
        failed.append("doc tests")
    if failed:
        print(f"error: tests failed in {', '.join(failed)}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
