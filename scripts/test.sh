#!/usr/bin/env bash
# Installs what is missing (scripts/setup.sh), builds the release configuration and runs the whole
# test suite (the README's test command).
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh
cmake --preset release
cmake --build --preset release -j "$(nproc)"
ctest --preset release -j 2 --timeout 900
