#!/usr/bin/env bash
# The GPU check, ready for the day a GPU is lent: one call, under 5 minutes
# on a GPU, that verifies every 3D catalog filter against the exact
# evaluator (exact fetches, and hardware-filtered linear fetches, which a
# GPU interpolates with its own fixed-point weights and lavapipe in float:
# the first thing to judge on real hardware), measures the
# generated-vs-hand-written table, and renders one row per filter, then
# writes a "## GPU" section into docs/BENCHMARKS.md (replacing an earlier
# one; the rest of the file is kept).
#
#   scripts/gpu-bench.sh                 the real run (release build)
#   scripts/gpu-bench.sh --small         a seconds-long run with small sizes
#                                        (what the test suite runs on lavapipe)
#   scripts/gpu-bench.sh --out FILE      write the section into FILE instead
#   scripts/gpu-bench.sh --adapter NAME  pick the adapter (substring)
#
# BOXFORGE_BIN: a boxforge binary to use instead of building the release one.
set -euo pipefail
cd "$(dirname "$0")/.."
small=false
out=docs/BENCHMARKS.md
adapter=()
while [ $# -gt 0 ]; do
    case "$1" in
        --small) small=true ;;
        --out) [ $# -ge 2 ] || { echo "error: --out needs a file; use scripts/gpu-bench.sh --out FILE" >&2; exit 2; }; out=$2; shift ;;
        --adapter) [ $# -ge 2 ] || { echo "error: --adapter needs a name; use scripts/gpu-bench.sh --adapter NAME" >&2; exit 2; }; adapter=(--adapter "$2"); shift ;;
        *) echo "error: unknown option '$1'; use scripts/gpu-bench.sh [--small] [--out FILE] [--adapter NAME]" >&2; exit 2 ;;
    esac
    shift
done
. scripts/ensure-vulkan.sh
if [ -n "${BOXFORGE_BIN:-}" ]; then
    bin=$BOXFORGE_BIN
else
    command -v cargo >/dev/null || { echo "error: cargo not found; install Rust from https://rustup.rs" >&2; exit 2; }
    echo "== building the release binary" >&2
    cargo build --release --locked -p boxforge-runtime --bin boxforge >&2
    bin=target/release/boxforge
fi
[ -x "$bin" ] || { echo "error: $bin is not an executable boxforge; unset BOXFORGE_BIN or build it" >&2; exit 2; }
if $small; then
    points=2000; volume=ml:16; size=48; smoke=(--smoke --runs 1)
else
    points=1000000; volume=ml:128; size=512; smoke=()
fi
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
start=$SECONDS

# The 3D catalog filters (the lattice column of `boxforge list`), hand-written schemes aside.
mapfile -t filters < <("$bin" list | awk '$2 == "bcc" || $2 == "cc" || $2 == "fcc" { if ($0 !~ /hand-written/) print $1 }')
[ ${#filters[@]} -gt 0 ] || { echo "error: boxforge list gave no 3D filter" >&2; exit 1; }

json_number() { # json_number NAME < one JSON object: the number, 3 significant digits
    local v
    v=$(sed -n "s/.*\"$1\":\([-0-9.eE+]*\)[,}].*/\1/p")
    [ -n "$v" ] && printf '%.3g' "$v"
}
json_string() { # json_string NAME < one JSON object
    sed -n "s/.*\"$1\":\"\([^\"]*\)\".*/\1/p"
}

section=$work/section.md
failed=0
{
    echo "## GPU"
    echo
    echo "Written by \`scripts/gpu-bench.sh$($small && echo ' --small')\` on $(date -u +%Y-%m-%d)."
    echo
} >"$section"

echo "== verify ($points points per filter)" >&2
verify_rows=$work/verify.md
adapter_line=""
for f in "${filters[@]}"; do
    for fetch in exact linear; do
        layout=embedded
        if [ "$fetch" = linear ]; then
            # Linear fetches: the embedded layout for one-coset tensor products, packed for the rest.
            case "$f" in cc_*) layout=embedded ;; *) layout=packed ;; esac
            case "$f" in bcc_sheared_trilinear) continue ;; esac
        fi
        if line=$("$bin" verify --filter "$f" --layout "$layout" --fetch "$fetch" --points "$points" --json "${adapter[@]}" 2>"$work/err"); then
            [ -n "$adapter_line" ] || adapter_line=$(json_string adapter <<<"$line")
            err=$(json_number max_abs_err <<<"$line")
            range=$(json_number data_range <<<"$line")
            grad=$(json_number max_rel_grad_err <<<"$line")
            passed=$(sed -n 's/.*"passed":\(true\|false\).*/\1/p' <<<"$line")
            verdict=$([ "$passed" = true ] && echo PASSED || echo FAILED)
            [ "$passed" = true ] || failed=$((failed + 1))
            printf '| %s | %s | %s | %s | %s | %s | %s |\n' "$f" "$layout" "$fetch" "$err" "$range" "$grad" "$verdict" >>"$verify_rows"
        else
            why=$(head -n 1 "$work/err" | tr '|' '/')
            printf '| %s | %s | %s | | | | not run: %s |\n' "$f" "$layout" "$fetch" "$why" >>"$verify_rows"
        fi
    done
done
{
    echo "Adapter: ${adapter_line:-unknown}"
    echo
    echo "### Verify against the exact evaluator ($points random points per row)"
    echo
    echo "| filter | layout | fetch | max \\|value error\\| | data range | max relative gradient error | result |"
    echo "|---|---|---|---|---|---|---|"
    cat "$verify_rows"
    echo
} >>"$section"

echo "== generated vs hand-written" >&2
refs=$work/refs.md
if "$bin" bench --references-only "${smoke[@]}" --markdown "$refs" "${adapter[@]}" >"$work/bench.out" 2>&1; then
    {
        echo "### Generated vs hand-written"
        echo
        # The bench's own section, its headings one level down.
        awk '/^## Generated vs hand-written/ { on = 1; next } on && /^## / { on = 0 } on { sub(/^### /, "#### "); print }' "$refs"
        echo
    } >>"$section"
else
    failed=$((failed + 1))
    { echo "### Generated vs hand-written"; echo; echo "not run: $(tail -n 1 "$work/bench.out")"; echo; } >>"$section"
fi

echo "== rendering ($volume at ${size}^2)" >&2
{
    echo "### Rendering ($volume, ${size}x${size}, isosurface at 0.5, fixed steps, the default view)"
    echo
    echo "| filter | ms per frame | empty blocks |"
    echo "|---|---|---|"
} >>"$section"
for f in "${filters[@]}"; do
    if msg=$("$bin" render --filter "$f" --volume "$volume" --size "$size" --out "$work/$f.png" "${adapter[@]}" 2>&1); then
        ms=$(sed -n 's/.* in \([0-9.]*\) ms per frame.*/\1/p' <<<"$msg" | tail -n 1)
        empty=$(sed -n 's/.*(\([0-9]*% of blocks empty\)).*/\1/p' <<<"$msg" | tail -n 1)
        printf '| %s | %s | %s |\n' "$f" "${ms:-?}" "${empty:-}" >>"$section"
    else
        failed=$((failed + 1))
        printf '| %s | not run: %s | |\n' "$f" "$(tail -n 1 <<<"$msg" | tr '|' '/')" >>"$section"
    fi
done
echo >>"$section"
echo "Total: $((SECONDS - start)) s." >>"$section"

# Splice: replace the "## GPU" section of $out (up to the next "## "), or append it.
touch "$out"
awk -v sec="$section" '
    function emit() { while ((getline l < sec) > 0) print l; done = 1 }
    /^## GPU$/ { skip = 1; emit(); next }
    skip && /^## / { skip = 0; print ""; }
    !skip { print }
    END { if (!done) { print ""; emit() } }
' "$out" >"$work/out.md"
cp "$work/out.md" "$out"
echo "== wrote the GPU section of $out in $((SECONDS - start)) s ($failed failed)" >&2
[ "$failed" -eq 0 ]
