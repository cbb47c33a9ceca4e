#!/usr/bin/env bash
# The main job: derive every catalog filter and write the generated output
# (reports; shaders and images as those stages land) into shaders-out/.
set -euo pipefail
cd "$(dirname "$0")/.."
command -v cargo >/dev/null || { echo "error: cargo not found; install Rust from https://rustup.rs" >&2; exit 2; }
. scripts/ensure-vulkan.sh
cargo build --release --locked -p boxforge-runtime
./target/release/boxforge generate --all -o shaders-out
echo "Catalog summary:"
./target/release/boxforge list
