#!/usr/bin/env bash
# Render time and rays per second of every strategy (default sample counts, 1 camera sample
# per pixel) on the shipped scenes at 256x256. Prints a table; the JSON stats stay in $OUT.
set -euo pipefail
cd "$(dirname "$0")/.."
OUT="${OUT:-target/measure-strategies}"
mkdir -p "$OUT"
cargo build --release -q -p veach-cli
printf "%-12s %-8s %-10s %9s %12s %10s\n" scene strategy samples render_s rays Mrays/s
for scene in cornell-box veach-mis; do
  for strategy in uniform brdf light mis; do
    json="$OUT/$scene-$strategy.json"
    target/release/veach render "assets/$scene.gltf" -o "$OUT/$scene-$strategy.exr" \
      --strategy "$strategy" --width 256 --height 256 --spp 1 --quiet --stats "$json"
    python3 - "$json" "$scene" "$strategy" <<'PY'
import json, sys
s = json.load(open(sys.argv[1]))
st = s["settings"]
samples = f'{st["light_samples"] if sys.argv[3] in ("light","mis") else 0}+{st["brdf_samples"] if sys.argv[3] != "light" else 0}'
print(f'{sys.argv[2]:<12} {sys.argv[3]:<8} {samples:<10} {s["timings_seconds"]["render"]:9.3f} {s["rays"]:12d} {s["rays_per_second"]/1e6:10.2f}')
PY
  done
done
