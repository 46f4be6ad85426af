#!/usr/bin/env bash
# Participating media (issue 39, docs/BENCHMARKS.md "Participating media"):
#
#     bash tests/bench/media.sh [BUILD_DIR] [SIZE]      # SIZE: medium (default) or full
#
# 1. Time against error: pt, bpt and vcm on the built-ins with media (cornell-fog,
#    cornell-smoke, cornell-tinted), each against a long bpt reference made with another
#    seed, by tests/bench/convergence.sh (SIZE), which prints the seconds to relative RMSE
#    0.2, 0.1 and 0.05 and the fitted slopes, and draws the plots.
# 2. Rays per second of pt and vcm with and without media: cornell, cornell-fog and
#    cornell-smoke at 256 x 256, 16 iterations, the median of three runs of each.
# 3. Memory of a 256^3 density grid: peak resident memory of one iteration of a scene
#    whose medium reads a 256^3 .vdb grid, against the same scene with a homogeneous medium.
set -euo pipefail
build=${1:-build}
size=${2:-medium}
here=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
vcmfarm=$build/vcmfarm
[ -x "$vcmfarm" ] || { echo "media.sh: no $vcmfarm (build first, or pass BUILD_DIR)" >&2; exit 2; }

echo "## 1. Time against error ($size)"
SCENES="cornell-fog cornell-smoke cornell-tinted" ALGORITHMS="pt bpt vcm" bash "$here/convergence.sh" "$size" "$build"

echo
echo "## 2. Rays per second (256 x 256, 16 iterations, median of 3)"
printf "| scene | algorithm | Mrays/s | iterations/s |\n|---|---|---|---|\n"
for scene in cornell cornell-fog cornell-smoke; do
  for a in pt vcm; do
    rates=() its=()
    for k in 1 2 3; do
      line=$("$vcmfarm" render "$scene" --direct -a "$a" -n 16 -R 256x256 -o /dev/null 2>&1 | grep '^rendered')
      rates+=("$(sed -E 's/.* ([0-9.]+) Mrays\/s.*/\1/' <<<"$line")")
      its+=("$(sed -E 's/.*: ([0-9.]+) it\/s.*/\1/' <<<"$line")")
    done
    median() { printf "%s\n" "$@" | sort -g | sed -n 2p; }
    printf "| %s | %s | %s | %s |\n" "$scene" "$a" "$(median "${rates[@]}")" "$(median "${its[@]}")"
  done
done

echo
echo "## 3. Memory of a 256^3 grid"
grid_tool=$build/tests/worker/scene/make_vdb
if [ -x "$grid_tool" ]; then
  tmp=$(mktemp -d)
  trap 'rm -rf "$tmp"' EXIT
  "$grid_tool" "$tmp/blob.vdb" 256
  for kind in grid homogeneous; do
    if [ "$kind" = grid ]; then density=", 'density': {'file': 'blob.vdb'}"; else density=""; fi
    sed "s/'/\"/g" > "$tmp/$kind.json" <<EOF
{'camera': {'position': [0, 0, 4], 'forward': [0, 0, -1], 'up': [0, 1, 0], 'fov': 40, 'resolution': [128, 128]},
 'media': {'smoke': {'sigma_a': 0.5, 'sigma_s': 2$density}},
 'materials': {'white': {'diffuse': [0.7, 0.7, 0.7]}},
 'shapes': [{'type': 'mesh', 'file': 'box', 'interior': 'smoke'}],
 'lights': [{'type': 'point', 'position': [0, 3, 3], 'intensity': [10, 10, 10]}]}
EOF
    /usr/bin/time -f "%M" -o "$tmp/$kind.rss" "$vcmfarm" render "$tmp/$kind.json" --direct -a pt -n 1 -o /dev/null \
      > /dev/null 2>&1 || { echo "render of $kind failed" >&2; exit 1; }
    printf "%s: peak resident %.1f MiB\n" "$kind" "$(awk '{ print $1 / 1024 }' "$tmp/$kind.rss")"
  done
else
  echo "(no $grid_tool: built with the scene tests)"
fi
