#!/usr/bin/env bash
# Renderer throughput: iterations/s and rays/s of every algorithm on a scene, medians of
# several runs, beside the raw Embree rate on the same scene. Prints a Markdown table.
# The raw rate (bench_embree's mix) is measured again right before each algorithm's runs
# and each algorithm's rays/s is set against that measurement: on a shared host the
# speed drifts within minutes, and a ratio of two rates taken minutes apart drifts with it.
# The raw rate is that of single rays (rtcIntersect1, rtcOccluded1), the baseline issue 2
# names; the renderer traces packets, and the "packet mix" column gives the rate of the
# same rays traced that way, for context.
# Two rates per algorithm: over the whole run, and after its first iteration ("steady"),
# which `vcmfarm render` prints too. The first iteration also pays for the first touches
# of the renderer's buffers (about 50k page faults at 512x512); the raw rate, traced from
# rays prepared beforehand, pays for no such thing, and neither does an iteration of a
# long render. "of raw" sets the steady rate against the raw one.
#
#   [RESOLUTION=WxH] [ALGORITHMS="vcm bpt pt"] tests/bench/renderer.sh [BUILD_DIR] [SCENE] [ITERATIONS] [RUNS]
#   defaults: build cornell 12 5, 512x512, all six algorithms (max path length 10, 2 threads)
set -euo pipefail
build="${1:-build}"
scene="${2:-cornell}"
iterations="${3:-12}"
runs="${4:-5}"
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
source "$(dirname "$0")/renderer_lib.sh"

echo "scene $scene, ${RESOLUTION:-512x512}, max path length 10, 2 threads, $iterations iterations per run, median of $runs runs"
echo
echo "| algorithm | iterations/s | Mrays/s | steady iterations/s | steady Mrays/s | raw Embree mix Mrays/s | of raw (steady) | packet mix Mrays/s | light pass ms/it | grid ms/it | camera pass ms/it |"
echo "|---|---|---|---|---|---|---|---|---|---|---|"
for algorithm in ${ALGORITHMS:-vcm bpt pt lt ppm bpm}; do
  raw_bench "$build" "$scene" "$tmp/raw"
  raw=$(raw_mix "$tmp/raw")
  packet=$(packet_mix "$tmp/raw")
  : >"$tmp/runs"
  for _ in $(seq "$runs"); do
    render_bench "$build" "$scene" "$algorithm" "$iterations" "$tmp/film.exr" "$tmp/log"
    rate=$(sed -n 's/^rendered.*: \([0-9.]*\) it\/s, \([0-9.]*\) Mrays\/s.*/\1 \2/p' "$tmp/log")
    steady=$(steady_rates "$tmp/log")
    phases=$(sed -n 's/per iteration: light sub-paths \([0-9.]*\) ms, grid \([0-9.]*\) ms, camera sub-paths \([0-9.]*\) ms.*/\1 \2 \3/p' "$tmp/log")
    echo "$rate $steady $phases" >>"$tmp/runs"
  done
  cols=()
  for c in 1 2 3 4 5 6 7; do cols+=("$(awk -v c=$c '{print $c}' "$tmp/runs" | median)"); done
  share=$(awk -v r="${cols[3]}" -v m="$raw" 'BEGIN {printf "%.1f%%", 100 * r / m}')
  echo "| $algorithm | ${cols[0]} | ${cols[1]} | ${cols[2]} | ${cols[3]} | $raw | $share | $packet | ${cols[4]} | ${cols[5]} | ${cols[6]} |"
done
echo
"$build/tests/bench_embree" "$scene" 2 4000000
