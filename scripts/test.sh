#!/usr/bin/env bash
# The whole test suite: formatting, packaging, clippy and rustdoc without
# warnings, every crate with no default features and with each feature
# alone, unit tests, integration tests, property tests, CLI tests, the
# browser test, the Python package's tests (pytest, with Dask), and
# examples/embed as a package of its own. Prints the time
# of each phase.
#
#   scripts/test.sh           the whole suite (what CI runs)
#   scripts/test.sh --quick   the inner loop: every test but the browser's,
#                             no fmt, packaging, clippy, feature builds or rustdoc
set -euo pipefail
cd "$(dirname "$0")/.."
quick=false
case "${1:-}" in
    "") ;;
    --quick) quick=true ;;
    *) echo "error: unknown option '$1'; use scripts/test.sh [--quick]" >&2; exit 2 ;;
esac
command -v cargo >/dev/null || { echo "error: cargo not found; install Rust from https://rustup.rs" >&2; exit 2; }
command -v python3 >/dev/null || { echo "error: python3 not found (the feature and test runners read cargo's JSON with it); install it, e.g.: sudo apt-get install -y python3" >&2; exit 2; }
. scripts/ensure-vulkan.sh
. scripts/ensure-compilers.sh
start=$SECONDS
phase() {
    local name=$1; shift
    local t0=$SECONDS
    echo "== $name" >&2
    "$@"
    echo "== $name: $((SECONDS - t0)) s" >&2
}
if $quick; then
    # The browser test skips itself without Chromium (BOXFORGE_NO_BROWSER).
    export BOXFORGE_NO_BROWSER=1
else
    # A whole run builds every crate from scratch or nearly (clean clones,
    # CI, the feature builds): incremental compilation only adds its caches'
    # cost there. The inner loop (--quick) keeps it. An explicit
    # CARGO_INCREMENTAL wins.
    export CARGO_INCREMENTAL="${CARGO_INCREMENTAL:-0}"
    . scripts/ensure-chromium.sh
    for tool in fmt clippy; do
        cargo "$tool" --version >/dev/null 2>&1 || { echo "error: cargo $tool not found; install it with: rustup component add $( [ "$tool" = fmt ] && echo rustfmt || echo clippy )" >&2; exit 2; }
    done
    phase rustfmt cargo fmt --all -- --check
    phase packaging scripts/check-packaging.sh
    phase clippy cargo clippy --workspace --all-targets --locked -- -D warnings
    phase features scripts/check-features.sh
    RUSTDOCFLAGS="-D warnings" phase rustdoc cargo doc --workspace --no-deps --lib --locked
fi
# examples/embed is tested on its own below: in the workspace run the
# runtime would get the CLI's features through feature unification.
# The Python peers the OME-Zarr tests check against (ome-zarr-models, zarr), made once.
phase "zarr peers (venv)" scripts/zarr-peers/ensure-venv.sh >/dev/null
# The venv the Python package is tested in (maturin, numpy, dask, distributed, pytest), made once.
phase "python (venv)" scripts/python/ensure-venv.sh >/dev/null
phase "tests (build)" cargo test --workspace --exclude boxforge-embed --locked --no-run
phase tests scripts/run-tests.py --workspace --exclude boxforge-embed
# The Python package (python/): the extension the build above made, under pytest.
phase python scripts/python/test.sh
phase "embed (own package)" cargo test --locked -p boxforge-embed
echo "== all passed in $((SECONDS - start)) s" >&2
