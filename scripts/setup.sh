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
  libcgal-dev libgmp-dev libmpfr-dev  # the random lattice's Delaunay triangulation (header-only CGAL)
  # the renderer (mca run --render, mca view): OpenGL through EGL (Mesa's llvmpipe without a GPU), GLFW
  # windows, PNG, video, the run's plots, and the window tests under a virtual X server
  libepoxy-dev libglm-dev libegl-dev libopengl-dev libegl-mesa0 libgl1-mesa-dri libglfw3-dev libpng-dev
  ffmpeg python3 python3-matplotlib xvfb xauth xdotool
  # the Python module mca (python/): built for Debian's /usr/bin/python3 and numpy, tested with pytest;
  # the Blender add-on (blender/) and its tests: Blender 3.4 runs that Python 3.11 with that numpy
  python3-dev python3-numpy python3-pybind11 pybind11-dev python3-pytest blender
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
# `import mca` for /usr/bin/python3 without PYTHONPATH: mca.pth in its site folder names this checkout's
# build/release/python (Python skips the line until the build has made it). Debian's Python is externally
# managed (no pip); the last checkout whose set-up ran is the one imported.
python_path() {
  local site pth build
  site=$(/usr/bin/python3 -c 'import site; print(site.getsitepackages()[0])' 2>/dev/null) || return 0
  build="$(cd "$(dirname "$0")/.." && pwd)/build/release/python"
  pth="$site/mca.pth"
  [[ -f "$pth" && "$(cat "$pth")" == "$build" ]] && return 0
  if [[ $(id -u) -eq 0 ]]; then mkdir -p "$site" && echo "$build" >"$pth"
  elif command -v sudo >/dev/null; then sudo mkdir -p "$site" && echo "$build" | sudo tee "$pth" >/dev/null
  else echo "setup: not root: $pth not written; set PYTHONPATH=$build to import mca" >&2; return 0
  fi
  echo "setup: $pth -> $build (import mca)"
}
if ((${#missing[@]} == 0)); then
  echo "setup: all ${#packages[@]} packages present"
  models
  python_path
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
python_path
