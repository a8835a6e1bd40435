#!/usr/bin/env bash
# Shader variants timed against each other on a lent GPU, with one carried binary: each folder
# under .gpu/shaders holds a whole copy of shaders/ with one change, which the binary reads at
# kernel creation through VEACH_SHADER_DIR (crates/veach/src/shaders.rs); `built-in` is the
# binary's own shaders. Shader-only experiments (a branch that changes no Rust) need no build of
# their own. For each variant: `veach scale`'s light sweep at 1920x1080, 256 spp (1 and 10,000
# lights, MIS 1 + 1 and light 2) and scripts/gpu-rays.sh on both shipped scenes at 512 spp.
#
#   VARIANTS     the folders' names, in order ("built-in" and every folder under .gpu/shaders)
#   EXECUTIONS   "wavefront" (or megakernel, auto; several run in turn)
#   RAYS         1 (0: leave out gpu-rays.sh)
#   WIDTH, HEIGHT, SPP   the light sweep's renders (1920, 1080, 256; small ones try the script on
#                lavapipe: WIDTH=64 HEIGHT=64 SPP=2 RAYS=0)
#
# Here, before the call: scripts/prepare-gpu-variants.sh (the binary, and a folder per experiment/*
# branch), or by hand:
#   cargo build --release && strip -o .gpu/veach target/release/veach
#   mkdir -p .gpu/shaders/NAME && git archive REF shaders | tar -x --strip-components=1 -C .gpu/shaders/NAME
# There: run(command="scripts/gpu-variants.sh", carry=[".gpu", ".gl"]): about 30 s a variant and
# execution on the H200. scale.csv and the renders' stats go to $OUT/VARIANT-EXECUTION/; a table
# of every variant against the first ends the output (scripts/gpu-variants-table.py).
set -euo pipefail
cd "$(dirname "$0")/.."
# shellcheck source=scripts/gpu-env.sh
. scripts/gpu-env.sh
out=${OUT:-target/gpu-variants}
variants=${VARIANTS:-built-in $(find .gpu/shaders -mindepth 1 -maxdepth 1 -type d -printf '%f\n' 2>/dev/null | sort)}
start=$SECONDS
for v in $variants; do
    if [ "$v" = built-in ]; then
        unset VEACH_SHADER_DIR
    else
        [ -d ".gpu/shaders/$v" ] || { echo "no folder .gpu/shaders/$v" >&2; exit 2; }
        export VEACH_SHADER_DIR=.gpu/shaders/$v
    fi
    for execution in ${EXECUTIONS:-wavefront}; do
        dir="$out/$v-$execution"
        mkdir -p "$dir"
        echo "== $v, $execution"
        "$veach" scale --triangles 0 --lights 1,10000 --width "${WIDTH:-1920}" --height "${HEIGHT:-1080}" --spp "${SPP:-256}" --repeats 5 \
            --execution "$execution" -o "$dir/scale" 2>&1 | grep -E '^\| [0-9]|warning|error' || true
        cp "$dir/scale/scale.csv" "$dir/" 2>/dev/null || true
        rm -rf "$dir/scale"
        if [ "${RAYS:-1}" = 1 ]; then
            OUT="$dir/rays" SPP=512 EXECUTIONS=$execution scripts/gpu-rays.sh 2>&1 | tail -4
        fi
        echo "($((SECONDS - start)) s)"
    done
done
# shellcheck disable=SC2086
python3 scripts/gpu-variants-table.py "$out" $variants || true
