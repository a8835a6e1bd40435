#!/usr/bin/env bash
# The GPU test binaries on a lent GPU machine (the `device` tool), with their whole output: the
# suite's statistical and image tests against a real driver instead of lavapipe. The machine has
# no Rust toolchain, so the test binaries are built here and carried, stripped (about 10 MB
# each; the carry limit is 64 MB together with the working tree):
#
#   cargo test --release --no-run
#   mkdir -p .gpu/tests
#   for t in analytic strategies sampling stress renderer; do
#       f=$(ls target/release/deps/$t-* | grep -v '\.d$' | head -1); strip -o .gpu/tests/$t "$f"
#   done
#   # the Vulkan loader debs into .gl, as scripts/gpu-check.sh's header says
#   run(command="scripts/gpu-tests.sh", carry=[".gpu/tests", ".gl"], timeout_s=330)
#
# The binaries find the assets and write their failure images through the paths they were built
# with (CARGO_MANIFEST_DIR, CARGO_TARGET_TMPDIR), so the checkout is linked there first. Each
# binary's output goes to $OUT/NAME.log, and a failed chi-square test's histograms and a failed
# image test's images (target/tmp/veach-tests) come back as $OUT/failures.tar.gz.
# On an H200 five binaries took 139-208 s, specialise 86-160 s of it (the driver compiles every kernel).
set -uo pipefail
cd "$(dirname "$0")/.."
out=${OUT:-target/gpu-tests}
mkdir -p "$out"
# shellcheck source=scripts/gpu-env.sh
. scripts/gpu-env.sh
built=${BUILT_AT:-/work/main}
if [ "$(realpath "$built" 2>/dev/null)" != "$(pwd -P)" ]; then
    mkdir -p "$(dirname "$built")" && ln -sfn "$(pwd -P)" "$built"
fi
mkdir -p target/tmp
status=0
for t in .gpu/tests/*; do
    name=$(basename "$t")
    echo "== $name"
    # --nocapture: the logs also keep what passing tests print (assert_same_image's differences).
    timeout "${TEST_TIMEOUT:-240}" "$t" --nocapture >"$out/$name.log" 2>&1 || status=1
    grep -E "^test result|FAILED|panicked" "$out/$name.log"
done
if [ -d target/tmp/veach-tests ]; then
    tar czf "$out/failures.tar.gz" --exclude=scenes -C target/tmp veach-tests
fi
exit $status
