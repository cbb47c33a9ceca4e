#!/usr/bin/env bash
# Builds each publishable crate with no default features and with each of
# its features alone (`cargo clippy -D warnings`: a gate that leaves an
# import unused is a break too), so that a feature one crate of the
# workspace turns on for another can no longer hide a break: `cargo test
# --workspace` unifies the features of all members.
#
#   scripts/check-features.sh [PACKAGE...]   (default: boxforge boxforge-runtime)
set -euo pipefail
cd "$(dirname "$0")/.."
packages=("$@")
[ ${#packages[@]} -gt 0 ] || packages=(boxforge boxforge-runtime)
features_of() {
    cargo metadata --no-deps --format-version 1 --locked | python3 -c '
import json, sys
name = sys.argv[1]
for p in json.load(sys.stdin)["packages"]:
    if p["name"] == name:
        print("\n".join(sorted(f for f in p["features"] if f != "default")))
' "$1"
}
for package in "${packages[@]}"; do
    sets=("")
    while IFS= read -r f; do [ -n "$f" ] && sets+=("$f"); done < <(features_of "$package")
    for f in "${sets[@]}"; do
        t0=$SECONDS
        cargo clippy --quiet --locked -p "$package" --no-default-features ${f:+--features "$f"} -- -D warnings || {
            echo "error: $package does not build with ${f:+only the feature '$f'}${f:-no default features}; fix the #[cfg(feature)] gates or the feature's dependencies in its Cargo.toml" >&2
            exit 1
        }
        echo "features: $package with ${f:-no default features} ($((SECONDS - t0)) s)" >&2
    done
done
