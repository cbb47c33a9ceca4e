#!/usr/bin/env bash
# Makes sure a Vulkan driver is installed (Mesa's lavapipe on machines without
# a GPU). Installs it with apt when running as root; otherwise prints the
# exact command and fails. Source it to also get a valid XDG_RUNTIME_DIR.
have_vulkan() {
    # Either folder may be missing: `ls` of both would fail when one is.
    { ls /usr/share/vulkan/icd.d/*.json >/dev/null 2>&1 || ls /etc/vulkan/icd.d/*.json >/dev/null 2>&1; } \
        && { ldconfig -p 2>/dev/null | grep 'libvulkan.so.1' >/dev/null || ls /usr/lib/*/libvulkan.so.1 >/dev/null 2>&1; }
}
if ! have_vulkan; then
    if [ "$(id -u)" = 0 ] && command -v apt-get >/dev/null; then
        echo "No Vulkan driver found: installing mesa-vulkan-drivers (lavapipe) with apt-get..." >&2
        apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq mesa-vulkan-drivers libvulkan1 >/dev/null
    else
        echo "error: no Vulkan driver found. Install one, e.g.: sudo apt-get install -y mesa-vulkan-drivers libvulkan1" >&2
        exit 2
    fi
fi
# Mesa warns unless XDG_RUNTIME_DIR is a private directory.
if [ -z "${XDG_RUNTIME_DIR:-}" ] || [ ! -d "${XDG_RUNTIME_DIR}" ]; then
    export XDG_RUNTIME_DIR="${TMPDIR:-/tmp}/boxforge-xdg-$(id -u)"
    mkdir -p -m 0700 "$XDG_RUNTIME_DIR"
fi
