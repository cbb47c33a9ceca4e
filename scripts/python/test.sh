#!/usr/bin/env bash
# Runs the Python package's tests (python/tests/*.py, pytest) against the
# extension `cargo test --workspace` built (target/debug/deps/lib_boxforge.so,
# the workspace's own build: no second compile): python/boxforge and that
# library are laid out as a package in target/python-pkg, which a .pth file
# puts on the venv's path (scripts/python/ensure-venv.sh makes the venv).
# The tests run the CLI at target/debug/boxforge (BOXFORGE_BIN) too.
#
#   scripts/python/test.sh [PYTEST ARGS...]
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)"
cd "$root"
target="${CARGO_TARGET_DIR:-$root/target}"
# The device boxforge.render opens: lavapipe, as for the other tests.
. scripts/ensure-vulkan.sh
py="$(scripts/python/ensure-venv.sh)"
# A cdylib keeps its plain name in deps/ (cargo test does not copy it up).
so="$target/debug/deps/lib_boxforge.so"
bin="$target/debug/boxforge"
if [ ! -f "$so" ] || [ ! -x "$bin" ]; then
    echo "error: $so or $bin is missing: build them first (cargo test --workspace --no-run, as scripts/test.sh does)" >&2
    exit 2
fi
pkg="$target/python-pkg"
rm -rf "$pkg"
mkdir -p "$pkg/boxforge"
# The package's Python files as links (edits show at once), and the
# extension as a copy (never through a link into python/: a `maturin
# develop` leaves its own build there, which this must not overwrite).
for f in python/boxforge/*.py python/boxforge/*.pyi python/boxforge/py.typed; do
    ln -s "$root/$f" "$pkg/boxforge/"
done
cp "$so" "$pkg/boxforge/_boxforge.abi3.so"
site="$("$py" -c 'import sysconfig; print(sysconfig.get_paths()["purelib"])')"
echo "$pkg" >"$site/boxforge-workspace.pth"
PYTHONDONTWRITEBYTECODE=1 BOXFORGE_BIN="$bin" "$py" -m pytest -q -p no:cacheprovider python/tests "$@"
