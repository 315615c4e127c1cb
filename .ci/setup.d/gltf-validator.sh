#!/usr/bin/env bash
# The Khronos glTF validator (npm package gltf-validator, pure JS compiled from Dart), used by
# tests/test_export.py through tests/tools/validate_gltf.js. Installed into .ci/node/ (git-ignored).
set -euo pipefail
cd "$(dirname "$0")/../.."
if ! command -v npm >/dev/null 2>&1 && command -v apt-get >/dev/null 2>&1 && [ "$(id -u)" = 0 ]; then
    apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq nodejs npm
fi
if ! command -v npm >/dev/null 2>&1; then
    echo "gltf-validator: npm not found; install Node.js (Debian: apt-get install -y nodejs npm)" >&2
    exit 1
fi
if [ ! -f .ci/node/node_modules/gltf-validator/package.json ]; then
    npm install --prefix .ci/node --no-audit --no-fund --no-save gltf-validator@2.0.0-dev.3.10
fi
node -e 'console.log("gltf-validator " + require("./.ci/node/node_modules/gltf-validator").version())'
