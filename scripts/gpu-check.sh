#!/usr/bin/env bash
# Issue 9's GPU checks in one call of the `device` tool (/work/.library/device/README.md): the
# adapter, two small renders to compare with lavapipe's (the same samples: the images should
# agree to rounding), rays per second (scripts/gpu-rays.sh: megakernel and wavefront, then
# other workgroup sizes), and `veach scale` at 1080p (the light sweep also with the wavefront).
# Each step has a time limit, so that one that hangs leaves the others their time. Everything
# lands in $OUT: gpu-check.log, the CSVs, the two small renders and gpu-check.tar.gz (every
# render's --stats JSON and log). The test suite on the GPU is scripts/gpu-tests.sh.
#
# The device machine starts bare. Here, once:
#   cargo build --release -p veach-cli
#   mkdir -p .gpu && strip -o .gpu/veach target/release/veach
#   printf '/.gpu/\n/.gl/\n' >> .git/info/exclude
#   mkdir -p .gl /tmp/amd64/partial; o='-oAPT::Architecture=amd64 -oAPT::Architectures=amd64 -oDir::State::Lists=/tmp/amd64'
#   apt-get $o update; (cd .gl && apt-get $o download libvulkan1 libglvnd0 libglx0 libgl1 libegl1 libopengl0 libgles2)
# then: run(command="scripts/gpu-check.sh", carry=[".gpu", ".gl"], timeout_s=480)
# (.gpu with the binary alone: with gpu-tests.sh's binaries beside it, it passes the 64 MB limit).
# On an H200 the call took 3.5 min (renders, scale and all), and starting the machine 0.5-3 min.
# Compare the small renders here with scripts/gpu-compare.py. On lavapipe, a quick try of the script:
#   VEACH=target/release/veach WIDTH=160 HEIGHT=90 SPP=2 REPEATS=1 GPU_WORKGROUPS=8x8 \
#   SCALE_OPTS="--triangles 1000 --lights 1,10 --repeats 1" scripts/gpu-check.sh
set -uo pipefail
cd "$(dirname "$0")/.."
# shellcheck source=scripts/gpu-env.sh
. scripts/gpu-env.sh
gpu_script_start gpu-check
export VEACH=$veach
step() { echo; echo "== $1 ($(date +%T))"; }

step "the machine as found"
nvidia-smi --query-gpu=name,driver_version,memory.total,clocks.sm,clocks.max.sm,temperature.gpu,power.draw,power.limit --format=csv 2>&1
nproc

step "small renders to compare with lavapipe (256x256, 64 spp, MIS 1 + 1, seed 1)"
for scene in cornell-box veach-mis; do
    timeout 60 "$veach" render "assets/$scene.gltf" --strategy mis --light-samples 1 --brdf-samples 1 \
        --light-selection power --width 256 --height 256 --spp 64 --seed 1 \
        --stats "$work/$scene-gpu.json" -o "$out/$scene-gpu.pfm" || echo "FAILED: $scene"
done
grep -h '"adapter"\|"driver"\|"device_type"' "$work/cornell-box-gpu.json"

workgroups=${GPU_WORKGROUPS:-8x8 16x16 32x8}
step "rays per second, megakernel and wavefront, workgroups $workgroups"
OUT=$work/rays SPP=${SPP:-512} WORKGROUPS=$workgroups timeout 200 scripts/gpu-rays.sh || echo "FAILED or timed out: gpu-rays"
cp "$work/rays/gpu-rays.csv" "$out/" 2>/dev/null
nvidia-smi --query-gpu=clocks.sm,clocks.mem,temperature.gpu,power.draw --format=csv 2>&1

scale_opts=${SCALE_OPTS:---width 1920 --height 1080 --spp 256 --repeats 5}
step "veach scale $scale_opts"
# shellcheck disable=SC2086
timeout 120 "$veach" scale -o "$work/scale" $scale_opts || echo "FAILED or timed out: scale"
cp "$work/scale/scale.csv" "$out/" 2>/dev/null

step "veach scale $scale_opts --triangles 0 --execution wavefront"
# shellcheck disable=SC2086
timeout 90 "$veach" scale -o "$work/scale-wavefront" $scale_opts --triangles 0 --execution wavefront ||
    echo "FAILED or timed out: scale, wavefront"
cp "$work/scale-wavefront/scale.csv" "$out/scale-wavefront.csv" 2>/dev/null

step "rays per second, megakernel, smaller workgroups"
OUT=$work/rays SPP=${SPP:-512} REPEATS=2 EXECUTIONS=megakernel WORKGROUPS="8x4 16x8" timeout 60 scripts/gpu-rays.sh ||
    echo "FAILED or timed out: workgroup sweep"
cp "$work/rays/gpu-rays.csv" "$out/" 2>/dev/null

step "packing"
cp "$work/rays/veach-mis-mis-megakernel-8x8.png" "$out/" 2>/dev/null
tar czf "$out/gpu-check.tar.gz" -C "$work" --exclude='*.png' --exclude='scenes' --exclude='*.gltf' --exclude='*.bin' . 2>&1
ls -la "$out"
