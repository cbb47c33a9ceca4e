#!/usr/bin/env bash
# The whole test suite: formatting, clippy and rustdoc without warnings,
# unit tests, integration tests, property tests and CLI tests for every
# crate of the workspace.
set -euo pipefail
cd "$(dirname "$0")/.."
command -v cargo >/dev/null || { echo "error: cargo not found; install Rust from https://rustup.rs" >&2; exit 2; }
. scripts/ensure-vulkan.sh
. scripts/ensure-chromium.sh
for tool in fmt clippy; do
    cargo "$tool" --version >/dev/null 2>&1 || { echo "error: cargo $tool not found; install it with: rustup component add $( [ "$tool" = fmt ] && echo rustfmt || echo clippy )" >&2; exit 2; }
done
cargo fmt --all -- --check
cargo clippy --workspace --all-targets --locked -- -D warnings
RUSTDOCFLAGS="-D warnings" cargo doc --workspace --no-deps --lib --locked
cargo test --workspace --locked
