#!/usr/bin/env bash
# Renderer throughput: iterations/s and rays/s of every algorithm on a scene, medians of
# several runs, beside the raw Embree rate on the same scene. Prints a Markdown table.
# The raw rate (bench_embree's mix) is measured again right before each algorithm's runs
# and each algorithm's rays/s is set against that measurement: on a shared host the
# speed drifts within minutes, and a ratio of two rates taken minutes apart drifts with it.
# The raw rate is that of single rays (rtcIntersect1, rtcOccluded1), the baseline issue 2
# names; the renderer traces packets, and the "packet mix" column gives the rate of the
# same rays traced that way, for context.
#
#   tests/bench/renderer.sh [BUILD_DIR] [SCENE] [ITERATIONS] [RUNS]
#   defaults: build cornell 8 5   (512x512, max path length 10, 2 threads)
set -euo pipefail
build="${1:-build}"
scene="${2:-cornell}"
iterations="${3:-8}"
runs="${4:-5}"
vcmfarm="$build/vcmfarm"
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT

median() { sort -g | awk '{v[NR] = $1} END {print v[int((NR + 1) / 2)]}'; }

echo "scene $scene, 512x512, max path length 10, 2 threads, $iterations iterations per run, median of $runs runs"
echo
echo "| algorithm | iterations/s | Mrays/s | raw Embree mix Mrays/s | of raw | packet mix Mrays/s | light pass ms/it | grid ms/it | camera pass ms/it |"
echo "|---|---|---|---|---|---|---|---|---|"
for algorithm in vcm bpt pt lt ppm bpm; do
  "$build/tests/bench_embree" "$scene" 2 2000000 >"$tmp/raw"
  raw=$(sed -n 's/.*mix 15% .*: \([0-9.]*\) Mrays\/s.*/\1/p' "$tmp/raw")
  packet=$(sed -n 's/.*packet mix: \([0-9.]*\) Mrays\/s.*/\1/p' "$tmp/raw")
  : >"$tmp/runs"
  for _ in $(seq "$runs"); do
    "$vcmfarm" render "$scene" --direct -a "$algorithm" -n "$iterations" -j 2 -R 512x512 -l 10 -o "$tmp/film.exr" 2>"$tmp/log"
    rate=$(sed -n 's/.*: \([0-9.]*\) it\/s, \([0-9.]*\) Mrays\/s.*/\1 \2/p' "$tmp/log")
    phases=$(sed -n 's/per iteration: light sub-paths \([0-9.]*\) ms, grid \([0-9.]*\) ms, camera sub-paths \([0-9.]*\) ms.*/\1 \2 \3/p' "$tmp/log")
    echo "$rate $phases" >>"$tmp/runs"
  done
  cols=()
  for c in 1 2 3 4 5; do cols+=("$(awk -v c=$c '{print $c}' "$tmp/runs" | median)"); done
  share=$(awk -v r="${cols[1]}" -v m="$raw" 'BEGIN {printf "%.0f%%", 100 * r / m}')
  echo "| $algorithm | ${cols[0]} | ${cols[1]} | $raw | $share | $packet | ${cols[2]} | ${cols[3]} | ${cols[4]} |"
done
echo
"$build/tests/bench_embree" "$scene" 2 4000000
