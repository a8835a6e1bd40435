#!/usr/bin/env bash
# The scene zoo on a GPU in one call of the `device` tool (/work/.library/device/README.md): every
# scene of `veach generate zoo` rendered at 1920x1080 with the defaults, its relMSE against a
# reference rendered there too, its efficiency and its rays per second (bench/zoo.py), and whether
# the 1M-triangle mesh holds 2 G rays/s of all kinds (camera, shadow and direction rays).
# Everything lands in $OUT: gpu-zoo.log (a line per scene as it finishes, so that a run cut short
# still says what it measured), zoo-table.md (bench/zoo.py's table) and zoo.csv; the images stay
# on the machine (1920x1080 PFMs are 25 MB each).
#
# Prepare the carried binary and Vulkan loader as for scripts/gpu-check.sh, then:
#   run(command="scripts/gpu-zoo.sh", carry=[".gpu", ".gl"], timeout_s=540)
# The machine's python3 has numpy. On lavapipe, a quick try of the script:
#   VEACH=target/release/veach WIDTH=64 HEIGHT=48 REF_SPP=16 SCENES=lights-1,mesh-blob-1k scripts/gpu-zoo.sh
set -uo pipefail
cd "$(dirname "$0")/.."
# shellcheck source=scripts/gpu-env.sh
. scripts/gpu-env.sh
gpu_script_start gpu-zoo
width=${WIDTH:-1920}
height=${HEIGHT:-1080}
spp=${SPP:-16}
reference_spp=${REF_SPP:-256}
min_rays=${MIN_RAYS_PER_SECOND:-2e9}
step() { echo; echo "== $1 ($(date +%T))"; }

step "the machine as found"
nvidia-smi --query-gpu=name,driver_version,memory.total,clocks.sm,clocks.max.sm --format=csv 2>&1
nproc

step "the zoo, seed ${SEED:-1}"
timeout 120 "$veach" generate zoo -o "$work/zoo" --seed "${SEED:-1}" || { echo "FAILED: generate zoo"; exit 1; }

step "bench/zoo.py at ${width}x${height}, $spp spp, references at $reference_spp spp"
scenes=()
if [ -n "${SCENES:-}" ]; then scenes=(--scenes "$SCENES"); fi
PYTHONUNBUFFERED=1 timeout "${ZOO_SECONDS:-420}" python3 bench/zoo.py "$work/zoo" -o "$work/bench" \
    --veach "$veach" --width "$width" --height "$height" --spp "$spp" --seeds 1 \
    --reference-spp "$reference_spp" --variant "defaults=" "${scenes[@]}" > "$out/zoo-table.md" ||
    echo "FAILED or timed out: bench/zoo.py"
cp "$work/bench/zoo.csv" "$out/" 2>/dev/null
cat "$out/zoo-table.md"

step "rays per second (the 1M-triangle mesh: at least $min_rays)"
python3 - "$out/zoo.csv" "$min_rays" <<'EOF'
import csv, sys
rows = list(csv.DictReader(open(sys.argv[1])))
floor = float(sys.argv[2])
for r in rows:
    print(f"{r['scene']:28} {float(r['rays_per_second']) / 1e9:8.3f} G rays/s  {float(r['seconds']):8.3f} s")
blob = [r for r in rows if r["scene"] == "mesh-blob-1m"]
if blob:
    rate = float(blob[0]["rays_per_second"])
    print(f"mesh-blob-1m: {rate / 1e9:.3f} G rays/s: {'holds' if rate >= floor else 'BELOW'} {floor / 1e9:g} G")
EOF
