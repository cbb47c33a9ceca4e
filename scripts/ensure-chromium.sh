#!/usr/bin/env bash
# Makes sure Chromium is installed for the browser viewer's test
# (runtime/tests/it/web.rs drives it headless over the DevTools protocol).
# Installs it with apt when running as root; otherwise prints the exact
# command and fails. Set BOXFORGE_CHROMIUM to use another Chromium binary.
find_chromium() {
    for c in "${BOXFORGE_CHROMIUM:-}" /usr/lib/chromium/chromium /usr/bin/chromium /usr/bin/chromium-browser; do
        [ -n "$c" ] && [ -x "$c" ] && { echo "$c"; return 0; }
    done
    return 1
}
if ! find_chromium >/dev/null; then
    if [ "$(id -u)" = 0 ] && command -v apt-get >/dev/null; then
        echo "No Chromium found: installing chromium with apt-get (for the browser viewer test)..." >&2
        apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq chromium >/dev/null
    else
        echo "error: Chromium not found (the browser viewer test needs it). Install it, e.g.: sudo apt-get install -y chromium" >&2
        exit 2
    fi
fi
BOXFORGE_CHROMIUM="$(find_chromium)"
export BOXFORGE_CHROMIUM
