#!/usr/bin/env bash
# Broken links of the heterogeneity presets over seeds: the default wall with clustered grains
# (scenes/heterogeneity_*.toml: grain_size = 0.2 m) struck at SPEED m/s, for seeds 1..SEEDS, one line per
# run and a summary per preset (mean and standard deviation). Usage:
#   tools/heterogeneity_seeds.sh [SEEDS=6] [SPEED=20] [MCA=build/release/mca]
# Each run is the full 60 ms of the scene without VTK (about 5-10 s on one core). docs/model-notes.md
# ("Heterogeneity over seeds") quotes its output.
set -euo pipefail
cd "$(dirname "$0")/.."
seeds=${1:-6}
speed=${2:-20}
mca=${3:-build/release/mca}
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
for seed in $(seq 1 "$seeds"); do
  for preset in none low medium high; do
    sed -e "s/^seed = 1\$/seed = $seed/" -e "s/^velocity = \\[0.0, 30.0, 0.0\\]/velocity = [0.0, $speed, 0.0]/" \
        -e "s/^preset = \"low\"/preset = \"$preset\"/" scenes/heterogeneity_low.toml > "$work/scene.toml"
    grep -q "seed = $seed" "$work/scene.toml" && grep -q "preset = \"$preset\"" "$work/scene.toml" &&
      grep -q "velocity = \\[0.0, $speed, 0.0\\]" "$work/scene.toml" ||
      { echo "heterogeneity_seeds.sh: scenes/heterogeneity_low.toml no longer has the lines this script edits" >&2; exit 1; }
    "$mca" run "$work/scene.toml" --out "$work/out" --no-vtk --quiet --threads 1 >/dev/null
    broken=$(python3 -c "import json,sys; print(json.load(open(sys.argv[1]))['broken_links']['total'])" "$work/out/summary.json")
    echo "$seed $preset $broken" | tee -a "$work/results.txt"
  done
done
python3 - "$work/results.txt" <<'PY'
import statistics, sys
runs = {}
for line in open(sys.argv[1]):
    seed, preset, broken = line.split()
    runs.setdefault(preset, []).append(int(broken))
for preset, v in runs.items():
    sd = statistics.stdev(v) if len(v) > 1 else 0.0
    print(f"{preset:7s} mean {statistics.mean(v):7.0f}  sd {sd:5.0f}  min {min(v)}  max {max(v)}")
PY
