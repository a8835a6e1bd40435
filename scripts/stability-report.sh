#!/usr/bin/env bash
# The stability suite's report: `veach bench` on every stress scene (crates/veach-scenes/src/
# stress.rs), area against solid-angle sampling of emitter triangles, written to docs/stability/
# (report.md, results.csv, a plot and an equal-time grid per scene). docs/stability.md reads it.
# Every stress scene by default (or those named in STRESS_SCENES="..."). About 4 minutes on
# 2 cores with lavapipe; run it alone (it measures time).
set -euo pipefail
cd "$(dirname "$0")/.."
cargo build --release -p veach-cli
veach=target/release/veach
scenes=$(mktemp -d)
trap 'rm -rf "$scenes"' EXIT
all="tiny-bright-light touching-light grazing-light near-mirrors many-lights far-cornell-box degenerate
    float-limits camera-inside"
for name in ${STRESS_SCENES:-$all}; do
    "$veach" generate "stress-$name" -o "$scenes/stress-$name.gltf"
done
"$veach" bench "$scenes"/stress-*.gltf -o docs/stability \
    --width 64 --height 64 --max-spp 32 --seeds 3 --reference-spp 1024 --hide-emitters \
    --strategies uniform,brdf,light,light-solid-angle,mis-balance,mis-balance-solid-angle,mis-lobes,mis-lobes-solid-angle \
    "$@"
