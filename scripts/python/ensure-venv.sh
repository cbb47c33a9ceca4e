#!/usr/bin/env bash
# Makes (once) the venv the `boxforge` Python package (python/) is built
# into and tested in: maturin, numpy, dask, distributed and pytest, pinned
# in scripts/python/requirements.txt. Prints its python's path on stdout.
# The venv is at ${BOXFORGE_PY_VENV:-target/python-venv} (a relative path is
# taken from the repository root); see scripts/venv.sh for when it is remade.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)"
# shellcheck source=../venv.sh
. "$root/scripts/venv.sh"
venv="${BOXFORGE_PY_VENV:-target/python-venv}"
case "$venv" in /*) ;; *) venv="$root/$venv" ;; esac
boxforge_venv "$venv" "$root/scripts/python/requirements.txt" "Python package"
