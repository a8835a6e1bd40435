#!/usr/bin/env bash
# Issue 9's GPU measurement in one short run: rays per second on both shipped scenes, with the
# light strategy (1 sample: camera + shadow rays) and MIS 1 + 1, at 1920x1080, each with the
# megakernel and with the wavefront kernels (issue 9 asks which wins on a GPU). Prints a table and
# writes gpu-rays.csv and each render's --stats JSON to $OUT (or target/gpu-rays).
#
# Made for a lent GPU machine (the `device` tool, /work/.library/device/README.md), which starts
# bare: build here, carry a stripped binary and the Vulkan loader, run this there.
#
#   cargo build --release -p veach-cli
#   mkdir -p .gpu && strip -o .gpu/veach target/release/veach      # ~25 MB; the carry limit is 64
#   echo /.gpu/ >> .git/info/exclude
#   # the loader debs into .gl, as the device README says (echo /.gl/ >> .git/info/exclude ...)
#   run(command="scripts/gpu-rays.sh", carry=[".gpu", ".gl"], timeout_s=300)
#
# Shadow rays are counted as the light strategy's rays less its camera rays (one per camera
# sample; a camera ray that misses the scene traces no shadow ray, so this under-counts none).
set -euo pipefail
cd "$(dirname "$0")/.."
if [ -d .gl ]; then
    for f in .gl/*.deb; do dpkg -x "$f" /; done
    ldconfig
fi
nvidia_icd=/usr/local/nvidia/share/vulkan/icd.d/nvidia_icd.json
if [ -z "${VK_DRIVER_FILES:-}" ] && [ -e "$nvidia_icd" ]; then export VK_DRIVER_FILES=$nvidia_icd; fi
veach=${VEACH:-.gpu/veach}
[ -x "$veach" ] || veach=target/release/veach
out=${OUT:-target/gpu-rays}
mkdir -p "$out"
width=${WIDTH:-1920} height=${HEIGHT:-1080} spp=${SPP:-16}
csv="$out/gpu-rays.csv"
echo "scene,strategy,execution,width,height,spp,render_s,rays,rays_per_s,shadow_rays_per_s,adapter" >"$csv"
printf "%-12s %-10s %-11s %10s %12s %12s %14s\n" scene strategy execution render_s rays Grays/s "shadow Grays/s"
for scene in cornell-box veach-mis; do
    for strategy in light mis; do
        case $strategy in
            light) opts=(--strategy light --light-samples 1) ;;
            mis) opts=(--strategy mis --light-samples 1 --brdf-samples 1 --heuristic power) ;;
        esac
        for execution in megakernel wavefront; do
            name="$scene-$strategy-$execution"
            stats="$out/$name.json"
            # A first render compiles the kernel; the second is timed.
            for pass in warm timed; do
                "$veach" render "assets/$scene.gltf" "${opts[@]}" --execution $execution \
                    --light-selection power --hide-emitters \
                    --width $width --height $height --spp "$spp" --seed 1 --stats "$stats" \
                    -o "$out/$name.png" >"$out/$name-$pass.log" 2>&1
            done
            python3 - "$stats" "$scene" "$strategy" "$execution" "$width" "$height" "$spp" "$csv" <<'EOF'
import json, sys
stats, scene, strategy, execution, w, h, spp, csv = sys.argv[1:]
s = json.load(open(stats))
# GPU timestamps where the adapter has them, else the wall clock of the dispatches.
seconds = s["timings_seconds"]["render_gpu"] or s["timings_seconds"]["render"]
rays = s["rays"]
camera = int(w) * int(h) * int(spp)
shadow = (rays - camera) / seconds if strategy == "light" else float("nan")
adapter = s["adapter"]
print(f"{scene:<12} {strategy:<10} {execution:<11} {seconds:10.4f} {rays:12d} {rays / seconds / 1e9:12.3f} {shadow / 1e9:14.3f}")
with open(csv, "a") as f:
    f.write(f"{scene},{strategy},{execution},{w},{h},{spp},{seconds},{rays},{rays / seconds},{shadow},{adapter}\n")
EOF
        done
    done
done
