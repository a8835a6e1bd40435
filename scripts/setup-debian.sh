#!/usr/bin/env bash
# Makes sure wgpu finds a Vulkan driver and the viewer's smoke test finds a display: on a
# Debian/Ubuntu machine without a Vulkan driver (no GPU, as in CI) installs Mesa's software
# Vulkan, lavapipe; without xvfb-run installs Xvfb. Safe to run again.
#
# --mesa-backports (Debian 12 only): install lavapipe from bookworm-backports (Mesa 25) instead
# of bookworm's Mesa 22.3. Same images bit for bit, 1.4-3.3x faster renders of the shipped scenes,
# 1.2x by the median zoo scene (docs/performance.md, "Mesa 22.3 against Mesa 25"); it replaces
# the system's Mesa packages, so it is opt-in.
set -euo pipefail
backports=no
for arg in "$@"; do
    case "$arg" in
        --mesa-backports) backports=yes ;;
        *) echo "usage: $0 [--mesa-backports]" >&2; exit 2 ;;
    esac
done
sudo=""
if [ "$(id -u)" != 0 ]; then sudo="sudo"; fi
packages=()
have_icd=no
for icd in /usr/share/vulkan/icd.d/*.json /etc/vulkan/icd.d/*.json; do
    if [ -e "$icd" ]; then have_icd=yes; fi
done
if [ "$backports" = yes ]; then
    . /etc/os-release
    if [ "${VERSION_CODENAME:-}" != bookworm ]; then
        echo "--mesa-backports is for Debian 12 (bookworm); this is ${PRETTY_NAME:-unknown}" >&2
        exit 1
    fi
    if ! grep -rqs bookworm-backports /etc/apt/sources.list /etc/apt/sources.list.d/; then
        echo "Adding bookworm-backports to the apt sources..." >&2
        printf '%s\n' "Types: deb" "URIs: http://deb.debian.org/debian" "Suites: bookworm-backports" \
            "Components: main" "Signed-By: /usr/share/keyrings/debian-archive-keyring.gpg" |
            $sudo tee /etc/apt/sources.list.d/bookworm-backports.sources >/dev/null
    fi
    echo "Installing Mesa's software Vulkan from bookworm-backports..." >&2
    $sudo apt-get update -qq
    DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq -t bookworm-backports mesa-vulkan-drivers >/dev/null
    have_icd=yes
fi
if [ "$have_icd" = no ]; then
    echo "No Vulkan driver found: installing Mesa's software Vulkan (mesa-vulkan-drivers)..." >&2
    packages+=(mesa-vulkan-drivers)
fi
if ! command -v xvfb-run >/dev/null; then
    echo "No xvfb-run: installing Xvfb (a virtual display for the viewer's window test)..." >&2
    packages+=(xvfb xauth)
fi
if [ ${#packages[@]} -eq 0 ]; then exit 0; fi
$sudo apt-get update -qq
DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq "${packages[@]}" >/dev/null
