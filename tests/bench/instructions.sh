#!/usr/bin/env bash
# Instructions per iteration of each algorithm, counted by valgrind's cachegrind: exact and
# repeatable, unlike times on a shared host, so a change of a few percent shows. Counts
# everything the process executes, Embree's traversal included; the start-up (scene, BVH,
# pool) cancels out by taking the difference of two runs. Prints a Markdown table, and a
# ratio column when a second build is given (the first is the baseline).
#
#   tests/bench/instructions.sh [BUILD_DIR] [OTHER_BUILD_DIR]
#   cornell at 128x128, max path length 10, one thread: (I(4 iterations) - I(2)) / 2
set -euo pipefail
build="${1:-build}"
other="${2:-}"
if ! command -v valgrind >/dev/null; then
  echo "instructions.sh: valgrind is not installed (apt-get install valgrind)" >&2
  exit 2
fi
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT

count() { # BUILD ALGORITHM ITERATIONS
  valgrind --tool=cachegrind --cache-sim=no --cachegrind-out-file=/dev/null \
    "$1/vcmfarm" render cornell --direct -a "$2" -n "$3" -j 1 -R 128x128 -l 10 -o "$tmp/film.exr" 2>&1 |
    sed -n 's/.*I *refs: *\([0-9,]*\).*/\1/p' | tr -d ,
}
per_iteration() { echo $((($(count "$1" "$2" 4) - $(count "$1" "$2" 2)) / 2)); }

echo "cornell, 128x128, max path length 10, one thread; instructions per iteration (cachegrind)"
echo
if [ -z "$other" ]; then
  echo "| algorithm | instructions/iteration |"
  echo "|---|---|"
else
  echo "| algorithm | $build | $other | ratio |"
  echo "|---|---|---|---|"
fi
for algorithm in vcm bpt pt lt ppm bpm; do
  a=$(per_iteration "$build" "$algorithm")
  if [ -z "$other" ]; then
    echo "| $algorithm | $a |"
  else
    b=$(per_iteration "$other" "$algorithm")
    echo "| $algorithm | $a | $b | $(awk -v a="$a" -v b="$b" 'BEGIN {printf "%.3f", b / a}') |"
  fi
done
