#!/usr/bin/env bash
# Refreshes the pictures in docs/ that tests produce (tests themselves never
# write tracked files): docs/web-viewer.png, the browser viewer's screenshot
# from runtime/tests/it/web.rs.
set -euo pipefail
cd "$(dirname "$0")/.."
. scripts/ensure-vulkan.sh
. scripts/ensure-chromium.sh
BOXFORGE_WEB_SCREENSHOT="$PWD/docs/web-viewer.png" \
    cargo test -p boxforge-runtime --test it --locked -- web::the_viewer_compiles_every_module_in_tint_and_matches_the_native_renderer --exact
echo "wrote docs/web-viewer.png"
