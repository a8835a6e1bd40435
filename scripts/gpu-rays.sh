#!/usr/bin/env bash
# Issue 9's GPU measurement: rays per second on both shipped scenes, with the light strategy
# (1 sample: camera + shadow rays) and MIS 1 + 1, at 1920x1080, with the megakernel and with the
# wavefront kernels (which wins on a GPU), and optionally with other workgroup sizes
# (VEACH_WORKGROUP). Prints a table and writes gpu-rays.csv and each render's --stats JSON to $OUT
# (or target/gpu-rays).
#
#   WIDTH, HEIGHT, SPP     image and camera samples per pixel (1920, 1080, 64)
#   REPEATS                timed renders per row, after one untimed (the kernel's compile); the
#                          median is reported (3)
#   EXECUTIONS             "megakernel wavefront" (or auto: what --execution auto picks)
#   WORKGROUPS             render kernels' workgroups, COLUMNSxROWS (auto: the adapter's choice)
#   SCENES, STRATEGIES     "cornell-box veach-mis", "light mis" (or uniform, brdf, mis-lobes:
#                          1 sample each, light + BRDF for mis-lobes)
#
# Made for a lent GPU machine (the `device` tool, /work/.library/device/README.md), which starts
# bare: build here, carry a stripped binary and the Vulkan loader, run there (scripts/gpu-check.sh
# runs this and the rest of the GPU checks in one call; its header says how to carry them).
#
# Shadow rays are counted as the light strategy's rays less its camera rays (one per camera
# sample; a camera ray that misses the scene traces no shadow ray, so this under-counts none).
set -euo pipefail
cd "$(dirname "$0")/.."
# shellcheck source=scripts/gpu-env.sh
. scripts/gpu-env.sh
out=${OUT:-target/gpu-rays}
mkdir -p "$out"
width=${WIDTH:-1920} height=${HEIGHT:-1080} spp=${SPP:-64} repeats=${REPEATS:-3}
csv="$out/gpu-rays.csv"
[ -e "$csv" ] || echo "scene,strategy,execution,workgroup,width,height,spp,render_s_median,render_s_all,rays,rays_per_s,shadow_rays_per_s,adapter" >"$csv"
printf "%-12s %-6s %-11s %-6s %10s %12s %9s %9s\n" scene strat execution wgroup render_s rays Grays/s "shadow G/s"
for scene in ${SCENES:-cornell-box veach-mis}; do
    for strategy in ${STRATEGIES:-light mis}; do
        case $strategy in
            light) opts=(--strategy light --light-samples 1) ;;
            mis) opts=(--strategy mis --light-samples 1 --brdf-samples 1 --heuristic power) ;;
            mis-lobes) opts=(--strategy mis-lobes --light-samples 1 --brdf-samples 1 --heuristic power) ;;
            brdf | uniform) opts=(--strategy "$strategy" --brdf-samples 1) ;;
            *) echo "unknown strategy $strategy" >&2; exit 2 ;;
        esac
        for execution in ${EXECUTIONS:-megakernel wavefront}; do
            for workgroup in ${WORKGROUPS:-auto}; do
                name="$scene-$strategy-$execution-$workgroup"
                stats=()
                # The first render compiles the kernel (and fills the driver's cache); the rest
                # are timed.
                for pass in $(seq 0 "$repeats"); do
                    # shellcheck disable=SC2046
                    env $([ "$workgroup" = auto ] || echo "VEACH_WORKGROUP=$workgroup") "$veach" render "assets/$scene.gltf" "${opts[@]}" \
                        --execution "$execution" --light-selection power --hide-emitters \
                        --width "$width" --height "$height" --spp "$spp" --seed 1 \
                        --stats "$out/$name-$pass.json" -o "$out/$name.png" >"$out/$name-$pass.log" 2>&1 ||
                        { echo "$name pass $pass failed:"; cat "$out/$name-$pass.log"; exit 1; }
                    [ "$pass" = 0 ] || stats+=("$out/$name-$pass.json")
                done
                python3 - "$scene" "$strategy" "$execution" "$workgroup" "$width" "$height" "$spp" "$csv" "${stats[@]}" <<'PY'
import json, statistics, sys
scene, strategy, execution, workgroup, w, h, spp, csv, *files = sys.argv[1:]
runs = [json.load(open(f)) for f in files]
# GPU timestamps where the adapter has them, else the wall clock of the dispatches.
times = [s["timings_seconds"]["render_gpu"] or s["timings_seconds"]["render"] for s in runs]
seconds = statistics.median(times)
rays = runs[0]["rays"]
assert all(s["rays"] == rays for s in runs), "the same render traced different ray counts"
camera = int(w) * int(h) * int(spp)
shadow = (rays - camera) / seconds if strategy == "light" else float("nan")
adapter = runs[0]["adapter"]
# What "auto" chose: the kernel key records the execution and the workgroup.
kernel = runs[0]["kernel"]
if execution == "auto":
    execution = "auto:" + ("wave" if "wavefront: true" in kernel else "mega")
if workgroup == "auto":
    import re
    m = re.search(r"workgroup: \((\d+), (\d+)\)", kernel)
    workgroup = f"{m[1]}x{m[2]}" if m else "?"
print(f"{scene:<12} {strategy:<6} {execution:<11} {workgroup:<6} {seconds:10.4f} {rays:12d} {rays / seconds / 1e9:9.3f} {shadow / 1e9:9.3f}")
with open(csv, "a") as f:
    all_times = " ".join(f"{t:.5f}" for t in times)
    f.write(f"{scene},{strategy},{execution},{workgroup},{w},{h},{spp},{seconds},{all_times},{rays},{rays / seconds},{shadow},\"{adapter}\"\n")
PY
            done
        done
    done
done
