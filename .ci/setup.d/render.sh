#!/usr/bin/env bash
# Headless rendering (tumble.render, tests/test_render.py): VTK's wheel renders off-screen
# through EGL when there is no display, with Mesa's software rasteriser (llvmpipe) when there
# is no GPU. Those libraries come from Debian; install them only when missing.
set -euo pipefail
packages=(libegl1 libegl-mesa0 libgl1-mesa-dri libgbm1 libgl1)
missing=()
for p in "${packages[@]}"; do
    dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -eq 0 ]; then
    echo "render: system libraries present"
    exit 0
fi
echo "render: installing ${missing[*]}"
SUDO=""
[ "$(id -u)" -eq 0 ] || SUDO="sudo"
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update
$SUDO apt-get install -y --no-install-recommends "${missing[@]}"
