#!/usr/bin/env bash
# Builds the release configuration and runs the whole test suite (the README's test command).
set -euo pipefail
cd "$(dirname "$0")/.."
cmake --preset release
cmake --build --preset release -j "$(nproc)"
ctest --preset release -j 2 --timeout 900
