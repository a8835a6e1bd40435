#!/usr/bin/env bash
# Makes sure wgpu finds a Vulkan driver: on a Debian/Ubuntu machine without one (no GPU
# driver, as in CI), installs Mesa's software Vulkan, lavapipe. Safe to run again.
set -euo pipefail
for icd in /usr/share/vulkan/icd.d/*.json /etc/vulkan/icd.d/*.json; do
    if [ -e "$icd" ]; then
        exit 0
    fi
done
sudo=""
if [ "$(id -u)" != 0 ]; then sudo="sudo"; fi
echo "No Vulkan driver found: installing Mesa's software Vulkan (mesa-vulkan-drivers)..." >&2
$sudo apt-get update -qq
DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq mesa-vulkan-drivers >/dev/null
