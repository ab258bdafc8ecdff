#!/usr/bin/env bash
# Installs the build dependencies, builds mca and runs the built-in default scene (the README's first
# command). Extra arguments go to `mca run`, e.g. scripts/run_default.sh --out /tmp/wall.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh
cmake --preset release
cmake --build --preset release -j "$(nproc)"
build/release/mca run "$@"
