#!/usr/bin/env bash
# Installs the Debian 12 packages that building, testing and running mca need, and puts the paper's
# models into the models cache (scripts/get_models.sh; MCA_SETUP_MODELS=0 skips them).
# Idempotent: re-running it when everything is there takes about a second.
# Run as root (or through sudo). Set MCA_SETUP_PARAVIEW=1 to also install ParaView
# (pvbatch), used only to check the VTK output by eye; MCA_SETUP_FUZZ=1 the fuzzing toolchain
# (scripts/fuzz.sh).
set -euo pipefail

packages=(
  cmake g++ ninja-build pkg-config git
  libgtest-dev libgmock-dev libbenchmark-dev
  libtbb-dev libtomlplusplus-dev libcli11-dev libfmt-dev nlohmann-json3-dev
  libassimp-dev libopenvdb-dev libboost-iostreams-dev
  # the renderer (mca run --render, mca view): OpenGL through EGL (Mesa's llvmpipe without a GPU), GLFW
  # windows, PNG, video, the run's plots, and the window tests under a virtual X server
  libepoxy-dev libglm-dev libegl-dev libopengl-dev libegl-mesa0 libgl1-mesa-dri libglfw3-dev libpng-dev
  ffmpeg python3 python3-matplotlib xvfb xauth xdotool
  # the Blender add-on (blender/) and its tests: Blender 3.4 runs Debian's Python 3.11 with numpy
  blender python3-numpy
)
if [[ "${MCA_SETUP_MODELS:-1}" != 0 ]]; then
  packages+=(libcgal-demo)  # the paper's models (scripts/get_models.sh)
fi
if [[ "${MCA_SETUP_FUZZ:-0}" == 1 ]]; then
  packages+=(clang-14 libfuzzer-14-dev)
fi
if [[ "${MCA_SETUP_PARAVIEW:-0}" == 1 ]]; then
  packages+=(paraview python3-paraview)
fi

missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
models() {
  if [[ "${MCA_SETUP_MODELS:-1}" != 0 ]]; then "$(dirname "$0")/get_models.sh"; fi
}
if ((${#missing[@]} == 0)); then
  echo "setup: all ${#packages[@]} packages present"
  models
  exit 0
fi

SUDO=""
if [[ $(id -u) -ne 0 ]]; then
  command -v sudo >/dev/null || { echo "setup: run as root (missing: ${missing[*]})" >&2; exit 1; }
  SUDO=sudo
fi
echo "setup: installing ${missing[*]}"
$SUDO apt-get update -qq
DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}"
models
