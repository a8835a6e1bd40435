# Sourced by the scripts that run on a lent GPU machine (gpu-check.sh, gpu-zoo.sh, gpu-rays.sh,
# gpu-tests.sh): the carried Vulkan loader and libglvnd, which NVIDIA's Vulkan driver
# (libGLX_nvidia.so.0) links, unpacked from .gl once per machine; NVIDIA's ICD named where the
# loader does not look; $veach, the carried binary or else this checkout's build; and
# gpu_script_start.
if [ -d .gl ] && ! ldconfig -p | grep -q libGLdispatch.so.0; then
    for f in .gl/*.deb; do dpkg -x "$f" /; done
    ldconfig
fi
nvidia_icd=/usr/local/nvidia/share/vulkan/icd.d/nvidia_icd.json
if [ -z "${VK_DRIVER_FILES:-}" ] && [ -e "$nvidia_icd" ]; then export VK_DRIVER_FILES=$nvidia_icd; fi
veach=${VEACH:-.gpu/veach}
[ -x "$veach" ] || veach=target/release/veach

# A script's start: its results in $OUT (or target/NAME), its scratch in /tmp/NAME, emptied, and
# everything it prints copied to $out/NAME.log.
gpu_script_start() {
    out=${OUT:-target/$1}
    work=/tmp/$1
    rm -rf "$work" && mkdir -p "$out" "$work"
    exec > >(tee "$out/$1.log") 2>&1
}
