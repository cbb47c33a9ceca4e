#!/usr/bin/env bash
# The main job: derive the whole catalog and write its shaders and reports
# into shaders-out/, then render Marschner-Lobb and the MNI head with bcc7,
# bcc8, fcc6 and cc_tricubic on the GPU (lavapipe without one) into out/,
# and print the quality/speed table.
set -euo pipefail
cd "$(dirname "$0")/.."
command -v cargo >/dev/null || { echo "error: cargo not found; install Rust from https://rustup.rs" >&2; exit 2; }
. scripts/ensure-vulkan.sh
. scripts/ensure-compilers.sh
cargo build --release --locked -p boxforge-runtime
./target/release/boxforge demo --out out
