# Sourced by the scripts that make a Python venv (scripts/zarr-peers/,
# scripts/python/): boxforge_venv VENV REQUIREMENTS LABEL makes (once) a
# venv at VENV with pip install -r REQUIREMENTS and prints its python's
# path on stdout. The venv is reused while the sha256 of REQUIREMENTS
# matches the stamp written after a successful install, and rebuilt
# otherwise. Needs python3 with venv (installed with apt-get when missing
# and run as root), and PyPI (or a pip index set with PIP_INDEX_URL) on a
# fresh install. LABEL names the venv in messages.
boxforge_venv() {
    local venv="$1" req="$2" label="$3" stamp want log py
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
            echo "error: $venv exists and is not a Python venv; remove it or move the $label venv elsewhere" >&2
            return 2
        fi
        rm -rf "$venv"
    fi
    echo "Making the $label venv at $venv (pip install -r $req)..." >&2
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
        echo "error: pip could not install $req (see $log); to make it by hand: $by_hand" >&2
        return 2
    fi
    echo "$want" >"$stamp"
    rm -f "$log"
    echo "$py"
}
