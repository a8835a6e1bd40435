#!/usr/bin/env bash
# Times two veach builds against each other on one scene: alternating runs (A, B, A, B, ...), each
# build's render time (`render_gpu` from --stats: no kernel creation or uploads), medians, min-max
# and the ratio B/A, and whether the last images of the two are the same bit for bit.
#
#   cp target/release/veach /tmp/veach-a    # before the change
#   cp target/release/veach /tmp/veach-b    # after it
#   scripts/ab-render.sh /tmp/veach-a /tmp/veach-b assets/cornell-box.gltf 9 [RENDER OPTIONS]
#
# The render options default to the benchmark setting (MIS 1 + 1, power heuristic, power
# light selection, emitters hidden, 32 spp); options given after the run count replace them all.
# LP_NUM_THREADS=1 in the environment runs lavapipe on one thread, whose times
# spread less on a shared 2-core machine.
set -euo pipefail
if [ $# -lt 4 ]; then
    sed -n '2,13p' "$0" | sed 's/^# \{0,1\}//' >&2
    exit 2
fi
a=$1 b=$2 scene=$3 runs=$4
shift 4
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
options=(--strategy mis --light-samples 1 --brdf-samples 1 --heuristic power --light-selection power
    --hide-emitters --spp 32)
if [ $# -gt 0 ]; then options=("$@"); fi
render_seconds() {
    python3 -c 'import json, sys; print(json.load(open(sys.argv[1]))["timings_seconds"]["render_gpu"])' "$1"
}
times_a=() times_b=()
for _ in $(seq "$runs"); do
    for which in a b; do
        bin=$a
        if [ "$which" = b ]; then bin=$b; fi
        if ! "$bin" render "$scene" -o "$work/$which.pfm" "${options[@]}" --stats "$work/$which.json" \
            >/dev/null 2>"$work/$which.err"; then
            echo "$bin failed:" >&2
            cat "$work/$which.err" >&2
            exit 1
        fi
        if [ "$which" = a ]; then times_a+=("$(render_seconds "$work/a.json")"); else times_b+=("$(render_seconds "$work/b.json")"); fi
    done
done
python3 - "${times_a[*]}" "${times_b[*]}" <<'PY'
import statistics, sys
a, b = ([float(t) for t in arg.split()] for arg in sys.argv[1:3])
ma, mb = statistics.median(a), statistics.median(b)
print(f"A median {ma:.4f} s ({min(a):.4f}-{max(a):.4f}), B median {mb:.4f} s ({min(b):.4f}-{max(b):.4f}), "
      f"B/A {mb / ma:.3f}, {len(a)} runs each")
PY
if cmp -s "$work/a.pfm" "$work/b.pfm"; then echo "images: the same bit for bit"; else echo "images: differ"; fi
