#!/usr/bin/env bash
# Puts the paper's models (the cow, the bunny, the armadillo, and a few more) into the models cache,
# where scenes find them by name (docs/scene-format.md, "Mesh objects"): $XDG_CACHE_HOME/mca/models, else
# ~/.cache/mca/models. They come from Debian's libcgal-demo package, which ships them in
# /usr/share/doc/libcgal-dev/data.tar.gz. Debian gives no licence per data
# file, so they are never copied into the repository. scripts/setup.sh installs the package and calls this.
# Idempotent: a second run takes well under a second.
set -euo pipefail

models=(cow.off bunny00.off armadillo.off ellipsoid.off sphere.off elephant.off)
archive=/usr/share/doc/libcgal-dev/data.tar.gz
cache="${XDG_CACHE_HOME:-${HOME:-.}/.cache}/mca/models"

have_all=1
for m in "${models[@]}"; do [[ -s "$cache/$m" ]] || have_all=0; done
if ((have_all)); then
  echo "get_models: ${#models[@]} models present in $cache"
  exit 0
fi

if [[ ! -f "$archive" ]]; then
  echo "get_models: $archive is missing: Debian's libcgal-demo holds the models; install it with" >&2
  echo "get_models: sudo scripts/setup.sh (or apt-get install libcgal-demo), then run this again" >&2
  exit 1
fi

mkdir -p "$cache"
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
tar -xzf "$archive" -C "$tmp" "${models[@]/#/data/meshes/}"
for m in "${models[@]}"; do
  mv -f "$tmp/data/meshes/$m" "$cache/$m"
done
echo "get_models: ${#models[@]} models extracted to $cache"
