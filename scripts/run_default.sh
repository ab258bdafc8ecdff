#!/usr/bin/env bash
# Installs the build dependencies, builds mca and runs the built-in default scene (the README's first
# command), rendering it: the pictures, the video and the plots go to out/wall_ball/render/. Extra arguments
# go to `mca run`, e.g. scripts/run_default.sh --out /tmp/wall, or --render-colour damage.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh
cmake --preset release
cmake --build --preset release -j "$(nproc)"
build/release/mca run --render "$@"
