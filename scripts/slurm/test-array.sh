#!/usr/bin/env bash
# CI's test of the Slurm recipes on a one-node cluster (single-node.sh): a 4-task array renders
# 4 ranges of a 64-spp image, `veach merge` adds them, and the merge must equal the one-machine
# render up to float rounding (relMSE < 1e-10; one sample's noise is ~1e-2). Then a missing
# part must make the merge fail, naming its range, and a 2-task bench array must merge into one
# report. Run from anywhere (as root, or with sudo), after `cargo build --release`.
set -euo pipefail
root=$(cd "$(dirname "$0")/../.." && pwd)
veach="$root/target/release/veach"
[[ -x "$veach" ]] || cargo build --release -p veach-cli --manifest-path "$root/Cargo.toml"
# The cluster's setup needs root (packages, daemons): sudo where this is not root.
sudo=""
if [[ $EUID -ne 0 ]]; then sudo="sudo"; fi
# Daemons this test starts, it stops; a cluster that was already up is left running.
started=$(pgrep -x slurmctld >/dev/null && echo no || echo yes)
$sudo "$root/scripts/slurm/single-node.sh" >/dev/null
work=$(mktemp -d)
cleanup() {
    rm -rf "$work"
    if [[ $started == yes ]]; then $sudo "$root/scripts/slurm/single-node.sh" --stop; fi
}
trap cleanup EXIT
scene="$root/assets/veach-mis.gltf"
size=(--width 96 --height 64)

echo "slurm: rendering samples 0..64 as a 4-task array"
SCENE="$scene" SPP=64 OUT="$work/parts" VEACH="$veach" VEACH_ARGS="${size[*]}" \
    sbatch --wait --quiet --array=0-3 --chdir="$work" "$root/scripts/slurm/render-array.sbatch"
ls "$work"/parts
"$veach" merge "$work"/parts/part-*.exr -o "$work/merged.pfm" --expect-spp 64
"$veach" render "$scene" -o "$work/whole.pfm" --spp 64 "${size[@]}" -q
python3 - "$work/merged.pfm" "$work/whole.pfm" "$work/parts/part-0.exr" <<'PY'
import struct, sys
def pfm(path):
    with open(path, "rb") as f:
        assert f.readline().strip() == b"PF"
        w, h = map(int, f.readline().split())
        assert float(f.readline()) < 0, "little-endian PFM"
        return struct.unpack(f"<{w * h * 3}f", f.read(w * h * 12))
merged, whole = pfm(sys.argv[1]), pfm(sys.argv[2])
# relMSE as veach's bench computes it (crates/veach-bench/src/bench.rs, error_metrics; epsilon 1e-2).
rel = sum((a - b) ** 2 / (b * b + 1e-2) for a, b in zip(merged, whole)) / len(whole)
print(f"slurm: merged 4 parts against the one-machine render: relMSE {rel:.3e}")
assert rel < 1e-10, "the merge is not the one-machine render"
assert max(whole) > 0, "a black image proves nothing"
PY

echo "slurm: a missing part is an error that names its range"
rm "$work/parts/part-2.exr"
if "$veach" merge "$work"/parts/part-*.exr -o "$work/gap.exr" --expect-spp 64 2>"$work/err"; then
    echo "merge with a missing part succeeded" >&2
    exit 1
fi
grep -q "samples 32..48 are missing" "$work/err" || { cat "$work/err" >&2; exit 1; }
[[ ! -e "$work/gap.exr" ]]

echo "slurm: a 2-task bench array"
SCENES="$root/assets/cornell-box.gltf $root/assets/textured.gltf" OUT="$work/bench" VEACH="$veach" \
    VEACH_ARGS="--width 16 --height 16 --max-spp 1 --seeds 1 --strategies light --reference-spp 16" \
    sbatch --wait --quiet --array=0-1 --chdir="$work" "$root/scripts/slurm/bench-array.sbatch"
"$veach" bench --merge "$work"/bench/task-* -o "$work/bench-report"
[[ $(grep -c '^## ' "$work/bench-report/report.md") -eq 2 ]]
echo "slurm: passed"
