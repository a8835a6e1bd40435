#!/usr/bin/env bash
# The stability suite's report: `veach bench` on every stress scene (crates/veach/src/assets/
# stress.rs), area against solid-angle sampling of emitter triangles, written to docs/stability/
# (report.md, results.csv, a plot and an equal-time grid per scene). docs/stability.md reads it.
# Takes about 25 minutes on 2 cores with lavapipe; run it alone (it measures time).
set -euo pipefail
cd "$(dirname "$0")/.."
cargo build --release -p veach-cli
veach=target/release/veach
scenes=$(mktemp -d)
trap 'rm -rf "$scenes"' EXIT
for name in tiny-bright-light touching-light grazing-light near-mirrors many-lights far-cornell-box \
    degenerate float-limits camera-inside; do
    "$veach" generate "stress-$name" -o "$scenes/stress-$name.gltf"
done
"$veach" bench "$scenes"/stress-*.gltf -o docs/stability \
    --width 96 --height 96 --max-spp 64 --seeds 3 --reference-spp 2048 \
    --strategies uniform,brdf,light,light-solid-angle,mis-balance,mis-balance-solid-angle,mis-lobes,mis-lobes-solid-angle \
    "$@"
