#!/usr/bin/env bash
# The renderer's rays/s against the raw Embree rate, as pairs: the raw rate (bench_embree's
# single-ray mix, measured as renderer.sh does: tests/bench/renderer_lib.sh), then one render right after it, and
# their ratio; repeated, then the median, minimum and maximum of the ratios. On a shared
# host the speed drifts within minutes, and a render shortly after its own raw
# measurement is set against the host's state of that moment; many pairs show how the
# ratio is spread, which one table of renderer.sh cannot.
#
#   [RESOLUTION=WxH] [ITERATIONS=N] tests/bench/raw_ratio.sh [BUILD_DIR] [SCENE] [ALGORITHM] [PAIRS]
#   defaults: build cornell vcm 16   (512x512, max path length 10, 2 threads, 12 iterations,
#   the rate after the first iteration, as renderer.sh's "steady" column)
set -euo pipefail
build="${1:-build}"
scene="${2:-cornell}"
algorithm="${3:-vcm}"
pairs="${4:-16}"
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
source "$(dirname "$0")/renderer_lib.sh"

iterations="${ITERATIONS:-12}"
echo "scene $scene, $algorithm, ${RESOLUTION:-512x512}, max path length 10, 2 threads, $iterations iterations, $pairs pairs"
echo
echo "| time | raw Embree mix Mrays/s | steady Mrays/s | of raw |"
echo "|---|---|---|---|"
: >"$tmp/ratios"
for _ in $(seq "$pairs"); do
  raw_bench "$build" "$scene" "$tmp/raw"
  raw=$(raw_mix "$tmp/raw")
  render_bench "$build" "$scene" "$algorithm" "$iterations" "$tmp/film.exr" "$tmp/log"
  steady=$(steady_rates "$tmp/log" | awk '{print $2}')
  ratio=$(awk -v r="$steady" -v m="$raw" 'BEGIN {printf "%.1f", 100 * r / m}')
  echo "$ratio" >>"$tmp/ratios"
  echo "| $(date +%H:%M:%S) | $raw | $steady | $ratio% |"
done
echo
sort -g "$tmp/ratios" | awk '{v[NR] = $1; if ($1 >= 60) above++}
  END {printf "median %.1f%%, min %.1f%%, max %.1f%%; %d of %d pairs at 60%% or more\n",
       v[int((NR + 1) / 2)], v[1], v[NR], above, NR}'
