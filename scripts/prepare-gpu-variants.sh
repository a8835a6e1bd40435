#!/usr/bin/env bash
# Builds and strips the binary, and writes one folder of shaders per experiment branch (and the
# wavefront-runs branch at other run lengths, and main's shaders with straight-line samples forced
# on) under .gpu/shaders, for scripts/gpu-variants.sh on a lent GPU:
# run(command="scripts/gpu-variants.sh", carry=[".gpu", ".gl"]). Branches that change only
# shaders/ are measured by main's binary this way (docs/performance.md, "The wavefront taken apart
# on the H200"); a branch's folder without a constant main's binary sets runs with it left out.
#
#   scripts/prepare-gpu-variants.sh [BRANCH...]   (default: every experiment/* branch)
set -euo pipefail
cd "$(dirname "$0")/.."
cargo build --release -p veach-cli
mkdir -p .gpu
strip -o .gpu/veach target/release/veach
rm -rf .gpu/shaders
mkdir -p .gpu/shaders
branches=("$@")
if [ ${#branches[@]} -eq 0 ]; then
    mapfile -t branches < <(git for-each-ref --format='%(refname:short)' refs/heads/experiment/)
fi
for branch in "${branches[@]}"; do
    name=${branch#experiment/}
    # Only shaders/ may differ from main: the binary is main's.
    if ! git diff --quiet main..."$branch" -- . ':!shaders'; then
        echo "skipped $branch: it changes more than shaders/" >&2
        continue
    fi
    mkdir -p ".gpu/shaders/$name"
    git archive "$branch" shaders | tar -x --strip-components=1 -C ".gpu/shaders/$name"
    # Files main added since the branch (the subgroup votes), which its kernels never call: main's.
    for f in shaders/*.wgsl; do
        [ -e ".gpu/shaders/$name/$(basename "$f")" ] || cp "$f" ".gpu/shaders/$name/"
    done
    echo ".gpu/shaders/$name from $branch"
done
# The wavefront's camera samples per round (LIGHT_PASS_RUN, 4 on the branch) at 1, 2 and 8.
if [ -d .gpu/shaders/wavefront-runs ]; then
    for r in 1 2 8; do
        cp -r .gpu/shaders/wavefront-runs ".gpu/shaders/runs-$r"
        sed -i "s/LIGHT_PASS_RUN: u32 = 4u/LIGHT_PASS_RUN: u32 = ${r}u/" ".gpu/shaders/runs-$r/wavefront.wgsl"
        grep -q "LIGHT_PASS_RUN: u32 = ${r}u" ".gpu/shaders/runs-$r/wavefront.wgsl"
    done
fi
# main's shaders with straight-line camera samples wherever a kernel takes at most one direction
# sample (STRAIGHT_LINE_SAMPLE is set on Mesa 22 only, where it was measured).
mkdir -p .gpu/shaders/straight-line
cp shaders/*.wgsl .gpu/shaders/straight-line/
sed -i 's/if STRAIGHT_LINE_SAMPLE && AT_MOST_ONE_DIRECTION_SAMPLE/if AT_MOST_ONE_DIRECTION_SAMPLE/' \
    .gpu/shaders/straight-line/direct.wgsl
grep -q "if AT_MOST_ONE_DIRECTION_SAMPLE && !CONE_SAMPLING {" .gpu/shaders/straight-line/direct.wgsl
echo ".gpu/shaders/straight-line from main's shaders"
du -sh .gpu
