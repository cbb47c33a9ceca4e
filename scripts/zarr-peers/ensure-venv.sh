#!/usr/bin/env bash
# Makes (once) the Python venv with ome-zarr-models and zarr that
# scripts/zarr-peers/check_store.py runs in, and prints its python's path on
# stdout. Run it (python=$(scripts/zarr-peers/ensure-venv.sh)) or source it
# (it then also exports BOXFORGE_ZARR_PYTHON).
#
# The venv is at ${BOXFORGE_ZARR_VENV:-target/zarr-peers-venv} (a relative
# path is taken from the repository root). It is reused while the sha256 of
# scripts/zarr-peers/requirements-check.txt matches the stamp written after a
# successful install, and rebuilt otherwise. Needs python3 with venv, and
# PyPI (or a pip index set with PIP_INDEX_URL) on a fresh install.
boxforge_zarr_venv() {
    local root venv
    root="$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)" || return 2
    # shellcheck source=../venv.sh
    . "$root/scripts/venv.sh" || return 2
    venv="${BOXFORGE_ZARR_VENV:-target/zarr-peers-venv}"
    case "$venv" in /*) ;; *) venv="$root/$venv" ;; esac
    boxforge_venv "$venv" "$root/scripts/zarr-peers/requirements-check.txt" "OME-Zarr check"
}
if [ "${BASH_SOURCE[0]}" != "$0" ]; then
    BOXFORGE_ZARR_PYTHON="$(boxforge_zarr_venv)" || return 2
    export BOXFORGE_ZARR_PYTHON
    echo "$BOXFORGE_ZARR_PYTHON"
else
    boxforge_zarr_venv || exit 2
fi
