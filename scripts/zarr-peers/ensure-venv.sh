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
    local root req venv stamp want log py
    root="$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)" || return 2
    req="$root/scripts/zarr-peers/requirements-check.txt"
    venv="${BOXFORGE_ZARR_VENV:-target/zarr-peers-venv}"
    case "$venv" in /*) ;; *) venv="$root/$venv" ;; esac
    stamp="$venv/.boxforge-requirements.sha256"
    py="$venv/bin/python"
    want="$(sha256sum "$req" | cut -d' ' -f1)" || return 2
    if [ -x "$py" ] && [ -f "$stamp" ] && [ "$(cat "$stamp")" = "$want" ]; then
        echo "$py"
        return 0
    fi
    local by_hand="python3 -m venv '$venv' && '$venv/bin/pip' install -r '$req' && sha256sum '$req' | cut -d' ' -f1 > '$stamp'"
    if [ -e "$venv" ]; then
        if [ ! -f "$venv/pyvenv.cfg" ]; then
            echo "error: $venv exists and is not a Python venv; remove it or set BOXFORGE_ZARR_VENV to another path" >&2
            return 2
        fi
        rm -rf "$venv"
    fi
    echo "Making the OME-Zarr check venv at $venv (pip install -r scripts/zarr-peers/requirements-check.txt)..." >&2
    mkdir -p "$(dirname "$venv")" || return 2
    log="$venv.pip.log"
    if ! python3 -m venv "$venv" >"$log" 2>&1 && [ "$(id -u)" = 0 ] && command -v apt-get >/dev/null; then
        # Debian's python3 ships venv separately: install it, as root, and retry.
        rm -rf "$venv"
        echo "Installing python3-venv (apt-get)..." >&2
        { apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq python3-venv; } >>"$log" 2>&1
    fi
    if [ ! -x "$py" ] && ! { rm -rf "$venv" && python3 -m venv "$venv" >>"$log" 2>&1; }; then
        echo "error: 'python3 -m venv' failed (see $log; on Debian/Ubuntu: sudo apt-get install -y python3-venv); to make it by hand: $by_hand" >&2
        return 2
    fi
    if ! "$venv/bin/pip" install -q --disable-pip-version-check -r "$req" >>"$log" 2>&1; then
        echo "error: pip could not install scripts/zarr-peers/requirements-check.txt (see $log); to make it by hand: $by_hand" >&2
        return 2
    fi
    echo "$want" >"$stamp"
    rm -f "$log"
    echo "$py"
}
if [ "${BASH_SOURCE[0]}" != "$0" ]; then
    BOXFORGE_ZARR_PYTHON="$(boxforge_zarr_venv)" || return 2
    export BOXFORGE_ZARR_PYTHON
    echo "$BOXFORGE_ZARR_PYTHON"
else
    boxforge_zarr_venv || exit 2
fi
