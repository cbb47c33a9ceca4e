#!/usr/bin/env bash
# The whole test suite: formatting, unit tests, integration tests, property
# tests and CLI tests for every crate of the workspace.
set -euo pipefail
cd "$(dirname "$0")/.."
command -v cargo >/dev/null || { echo "error: cargo not found; install Rust from https://rustup.rs" >&2; exit 2; }
. scripts/ensure-vulkan.sh
cargo fmt --all -- --check
cargo test --workspace --locked
