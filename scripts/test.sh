#!/usr/bin/env bash
# The whole test suite: formatting, clippy and rustdoc without warnings,
# unit tests, integration tests, property tests, CLI tests and the browser
# test for every crate of the workspace. Prints the time of each phase.
#
#   scripts/test.sh           the whole suite (what CI runs)
#   scripts/test.sh --quick   the inner loop: every test but the browser's,
#                             no fmt, clippy or rustdoc
set -euo pipefail
cd "$(dirname "$0")/.."
quick=false
case "${1:-}" in
    "") ;;
    --quick) quick=true ;;
    *) echo "error: unknown option '$1'; use scripts/test.sh [--quick]" >&2; exit 2 ;;
esac
command -v cargo >/dev/null || { echo "error: cargo not found; install Rust from https://rustup.rs" >&2; exit 2; }
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
    BOXFORGE_NO_BROWSER=1 phase "tests (quick)" cargo test --workspace --locked
else
    . scripts/ensure-chromium.sh
    for tool in fmt clippy; do
        cargo "$tool" --version >/dev/null 2>&1 || { echo "error: cargo $tool not found; install it with: rustup component add $( [ "$tool" = fmt ] && echo rustfmt || echo clippy )" >&2; exit 2; }
    done
    phase rustfmt cargo fmt --all -- --check
    phase clippy cargo clippy --workspace --all-targets --locked -- -D warnings
    RUSTDOCFLAGS="-D warnings" phase rustdoc cargo doc --workspace --no-deps --lib --locked
    phase tests cargo test --workspace --locked
fi
echo "== all passed in $((SECONDS - start)) s" >&2
