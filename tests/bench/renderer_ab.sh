#!/usr/bin/env bash
# Two builds of the renderer side by side: `render --direct` of each, alternated run by run
# (A, B, A, B, ...), so that the host's drift from minute to minute falls on both alike.
# Prints every run's steady iterations/s (after the first iteration, as renderer.sh) and
# the median of each build, and B's median against A's.
#
#   [RESOLUTION=WxH] tests/bench/renderer_ab.sh BUILD_A BUILD_B [SCENE] [ALGORITHM] [ITERATIONS] [ROUNDS]
#   defaults: cornell pt 16 7, 512x512 (max path length 10, 2 threads)
set -euo pipefail
if [ $# -lt 2 ]; then
  echo "usage: [RESOLUTION=WxH] $0 BUILD_A BUILD_B [SCENE] [ALGORITHM] [ITERATIONS] [ROUNDS]" >&2
  exit 2
fi
builds=("$1" "$2")
scene="${3:-cornell}"
algorithm="${4:-pt}"
iterations="${5:-16}"
rounds="${6:-7}"
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
source "$(dirname "$0")/renderer_lib.sh"

echo "scene $scene, ${RESOLUTION:-512x512}, $algorithm, $iterations iterations per run, $rounds rounds, steady iterations/s"
for _ in $(seq "$rounds"); do
  for b in 0 1; do
    render_bench "${builds[$b]}" "$scene" "$algorithm" "$iterations" "$tmp/film.exr" "$tmp/log"
    rate=$(steady_rates "$tmp/log" | awk '{print $1}')
    if [ -z "$rate" ]; then
      echo "no steady rate from ${builds[$b]} (at least 2 iterations are needed):" >&2
      cat "$tmp/log" >&2
      exit 1
    fi
    echo "$rate" >>"$tmp/rates$b"
  done
done
for b in 0 1; do
  echo "${builds[$b]}: median $(median <"$tmp/rates$b") of $(tr '\n' ' ' <"$tmp/rates$b")"
done
awk -v a="$(median <"$tmp/rates0")" -v b="$(median <"$tmp/rates1")" \
  'BEGIN {printf "B against A: %+.1f%%\n", 100 * (b / a - 1)}'
