#!/usr/bin/env bash
# Makes sure wgpu finds a Vulkan driver and the viewer's smoke test finds a display: on a
# Debian/Ubuntu machine without a Vulkan driver (no GPU, as in CI) installs Mesa's software
# Vulkan, lavapipe; without xvfb-run installs Xvfb. Safe to run again.
set -euo pipefail
packages=()
have_icd=no
for icd in /usr/share/vulkan/icd.d/*.json /etc/vulkan/icd.d/*.json; do
    if [ -e "$icd" ]; then have_icd=yes; fi
done
if [ "$have_icd" = no ]; then
    echo "No Vulkan driver found: installing Mesa's software Vulkan (mesa-vulkan-drivers)..." >&2
    packages+=(mesa-vulkan-drivers)
fi
if ! command -v xvfb-run >/dev/null; then
    echo "No xvfb-run: installing Xvfb (a virtual display for the viewer's window test)..." >&2
    packages+=(xvfb xauth)
fi
if [ ${#packages[@]} -eq 0 ]; then exit 0; fi
sudo=""
if [ "$(id -u)" != 0 ]; then sudo="sudo"; fi
$sudo apt-get update -qq
DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq "${packages[@]}" >/dev/null
