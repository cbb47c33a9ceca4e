#!/usr/bin/env bash
# Checks that each publishable crate's package holds every file its code
# embeds: for every `include_str!("...")` / `include_bytes!("...")` with a
# literal path in the crate's src/, the path (resolved from the including
# file) must be inside the crate's folder and listed by `cargo package
# --list`. Cheap: it lists the package, it does not build it.
#
#   scripts/check-packaging.sh [CRATE_DIR...]   (default: generator runtime)
set -euo pipefail
cd "$(dirname "$0")/.."
status=0
dirs=("$@")
[ ${#dirs[@]} -gt 0 ] || dirs=(generator runtime)
for crate_dir in "${dirs[@]}"; do
    name=$(sed -n 's/^name = "\(.*\)"/\1/p' "$crate_dir/Cargo.toml" | head -1)
    listed=$(cargo package --list --allow-dirty --locked -p "$name" 2>/dev/null) || {
        echo "error: cargo package --list -p $name failed; run it to see why" >&2
        status=1
        continue
    }
    count=0
    before=$status
    while IFS=: read -r file literal; do
        [ -n "$file" ] || continue
        target=$(realpath -m -s --relative-to="$crate_dir" "$(dirname "$file")/$literal")
        count=$((count + 1))
        case "$target" in
            ../*) echo "error: $file embeds $literal, outside $crate_dir/: the published $name would not have it (put it under $crate_dir/, e.g. through a symlink)" >&2; status=1 ;;
            *) grep -qxF "$target" <<<"$listed" || { echo "error: $file embeds $literal, which 'cargo package --list -p $name' does not list" >&2; status=1; } ;;
        esac
    done < <(grep -rhoE --include='*.rs' -H 'include_(str|bytes)!\("[^"]+"\)' "$crate_dir/src" \
                | sed -E 's/^([^:]+):include_(str|bytes)!\("([^"]+)"\)$/\1:\3/')
    [ "$status" != "$before" ] || echo "packaging: $name lists all $count embedded files" >&2
done
exit $status
