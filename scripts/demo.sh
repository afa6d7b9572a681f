#!/usr/bin/env bash
# Sets up, builds and runs the main job on the built-in default scene. Usage: scripts/demo.sh [out-dir]
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh
cmake --preset default >/dev/null
cmake --build --preset default -j "$(nproc)" --target rtusim
exec build/default/rtusim demo --out "${1:-out/demo}"
