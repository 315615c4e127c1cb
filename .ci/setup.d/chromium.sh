#!/usr/bin/env bash
# Headless browser for the viewer tests (tests/test_viewer.py drives it with the
# Python playwright package through executable_path=/usr/bin/chromium; no
# `playwright install`, which downloads its own browsers).
set -euo pipefail
if [ -x /usr/bin/chromium ]; then
    echo "chromium: $(/usr/bin/chromium --version 2>/dev/null || echo present)"
    exit 0
fi
SUDO=""
if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update
$SUDO apt-get install -y --no-install-recommends chromium fonts-liberation
/usr/bin/chromium --version || true
