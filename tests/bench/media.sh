#!/usr/bin/env bash
# Participating media (issue 39, docs/BENCHMARKS.md "Participating media"):
#
#     bash tests/bench/media.sh [BUILD_DIR] [SIZE]      # SIZE: medium (default) or full
#
# 1. Time against error: pt, bpt, vcm and upg on the built-ins with media (cornell-fog,
#    cornell-smoke, cornell-tinted), each against a long bpt reference made with another
#    seed, by tests/bench/convergence.sh (SIZE), which prints the seconds to relative RMSE
#    0.2, 0.1 and 0.05 and the fitted slopes, and draws the plots.
# 2. Rays per second of pt, vcm and upg with and without media: cornell, cornell-fog and
#    cornell-smoke at 256 x 256, 16 iterations, the median of three runs of each.
# 3. Memory of a 256^3 density grid: resident memory before and after loading a scene
#    whose medium reads a 256^3 .vdb grid, and the peak (tests/bench/grid_memory.c).
set -euo pipefail
build=${1:-build}
size=${2:-medium}
here=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
vcmfarm=$build/vcmfarm
[ -x "$vcmfarm" ] || { echo "media.sh: no $vcmfarm (build first, or pass BUILD_DIR)" >&2; exit 2; }

echo "## 1. Time against error ($size)"
SCENES="cornell-fog cornell-smoke cornell-tinted" ALGORITHMS="pt bpt vcm upg" bash "$here/convergence.sh" "$size" "$build"

echo
echo "## 2. Rays per second (256 x 256, 16 iterations, median of 3)"
films=$(mktemp -d)
trap 'rm -rf "$films"' EXIT
printf "| scene | algorithm | Mrays/s | iterations/s |\n|---|---|---|---|\n"
for scene in cornell cornell-fog cornell-smoke; do
  for a in pt vcm upg; do
    rates=() its=()
    for k in 1 2 3; do
      line=$("$vcmfarm" render "$scene" --direct -a "$a" -n 16 -R 256x256 -o "$films/f.exr" 2>&1 | grep '^rendered')
      rates+=("$(sed -E 's/.* ([0-9.]+) Mrays\/s.*/\1/' <<<"$line")")
      its+=("$(sed -E 's/.*: ([0-9.]+) it\/s.*/\1/' <<<"$line")")
    done
    median() { printf "%s\n" "$@" | sort -g | sed -n 2p; }
    printf "| %s | %s | %s | %s |\n" "$scene" "$a" "$(median "${rates[@]}")" "$(median "${its[@]}")"
  done
done

echo
echo "## 3. Memory of a 256^3 grid"
"$build/tests/bench_grid_memory" 256
