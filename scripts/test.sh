#!/usr/bin/env bash
# Installs what is missing (scripts/setup.sh), builds the release configuration and runs the whole
# test suite (the README's test command).
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh
cmake --preset release
cmake --build --preset release -j "$(nproc)"
# The CPU backend's checks stay on the CPU on a machine with an NVIDIA GPU, which backend auto would take
# (MCA_BACKEND set by hand runs them on another backend).
export MCA_BACKEND=${MCA_BACKEND:-cpu}
ctest --preset release -j 2 --timeout 900
