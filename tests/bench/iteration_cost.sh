#!/usr/bin/env bash
# The cost of an iteration of two builds side by side, per scene and algorithm: cachegrind's
# instructions per iteration (exact, (I(4 iterations) - I(2)) / 2 at 128x128, as
# instructions.sh counts them) and the CPU seconds per iteration of the process (user +
# system, one thread), (CPU(N iterations) - CPU(1)) / (N - 1) at 256x256: the first
# iteration and the start-up cancel out. CPU times come from runs alternated build by build
# (A1, B1, AN, BN, A1, ...), so that the host's drift falls on both alike, ROUNDS of each:
# the table takes each build's fastest run of either length (on a shared machine other
# processes only ever add time), and its last column the ratio of the medians of the
# rounds' differences as a check. Prints a Markdown table. The independent sampler unless
# SAMPLER says otherwise.
#
#   [SCENES="cornell cornell-glossy cornell-env"] [ALGORITHMS="pt bpt vcm"] [SAMPLER=independent]
#   [ROUNDS=7] [MODE=both|instructions|cpu] tests/bench/iteration_cost.sh BUILD_A BUILD_B
set -euo pipefail
if [ $# -lt 2 ]; then
  echo "usage: [SCENES=...] [ALGORITHMS=...] [SAMPLER=S] [ROUNDS=R] [MODE=both|instructions|cpu] $0 BUILD_A BUILD_B" >&2
  exit 2
fi
builds=("$1" "$2")
scenes="${SCENES:-cornell cornell-glossy cornell-env}"
algorithms="${ALGORITHMS:-pt bpt vcm}"
sampler="${SAMPLER:-independent}"
rounds="${ROUNDS:-7}"
mode="${MODE:-both}"
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
source "$(dirname "$0")/renderer_lib.sh"

# Iterations a CPU run renders: about two seconds of one thread each.
iterations_of() { case "$1" in pt) echo 33 ;; *) echo 9 ;; esac; }

instructions() { # BUILD SCENE ALGORITHM ITERATIONS
  valgrind --tool=cachegrind --cache-sim=no --cachegrind-out-file=/dev/null \
    "$1/vcmfarm" render "$2" --direct -a "$3" -n "$4" -j 1 -R 128x128 -l 10 --sampler "$sampler" \
    --checkpoint-interval 0 -o "$tmp/film.exr" 2>&1 | sed -n 's/.*I *refs: *\([0-9,]*\).*/\1/p' | tr -d ,
}
per_iteration() { echo $((($(instructions "$1" "$2" "$3" 4) - $(instructions "$1" "$2" "$3" 2)) / 2)); }

cpu() { # BUILD SCENE ALGORITHM ITERATIONS: CPU seconds of the whole process
  /usr/bin/time -f "%U %S" -o "$tmp/time" "$1/vcmfarm" render "$2" --direct -a "$3" -n "$4" -j 1 -R 256x256 \
    -l 10 --sampler "$sampler" --checkpoint-interval 0 -o "$tmp/film.exr" 2>/dev/null
  awk '{printf "%.3f", $1 + $2}' "$tmp/time"
}

echo "instructions/iteration: 128x128, cachegrind; CPU s/iteration: 256x256, fastest of $rounds alternated runs;"
echo "one thread, max path length 10, --sampler $sampler. A: ${builds[0]}, B: ${builds[1]}"
echo
echo "| scene | algorithm | A instructions/it | B instructions/it | B/A | A CPU s/it | B CPU s/it | B/A | B/A (medians) |"
echo "|---|---|---|---|---|---|---|---|---|"
for scene in $scenes; do
  for algorithm in $algorithms; do
    ia="" ib="" ir="" ca="" cb="" cr="" mr=""
    if [ "$mode" != cpu ]; then
      ia=$(per_iteration "${builds[0]}" "$scene" "$algorithm")
      ib=$(per_iteration "${builds[1]}" "$scene" "$algorithm")
      ir=$(awk -v a="$ia" -v b="$ib" 'BEGIN {printf "%.3f", b / a}')
    fi
    if [ "$mode" != instructions ]; then
      n=$(iterations_of "$algorithm")
      : >"$tmp/a" && : >"$tmp/b" && : >"$tmp/a1" && : >"$tmp/an" && : >"$tmp/b1" && : >"$tmp/bn"
      for _ in $(seq "$rounds"); do
        a1=$(cpu "${builds[0]}" "$scene" "$algorithm" 1)
        b1=$(cpu "${builds[1]}" "$scene" "$algorithm" 1)
        an=$(cpu "${builds[0]}" "$scene" "$algorithm" "$n")
        bn=$(cpu "${builds[1]}" "$scene" "$algorithm" "$n")
        echo "$a1" >>"$tmp/a1" && echo "$an" >>"$tmp/an" && echo "$b1" >>"$tmp/b1" && echo "$bn" >>"$tmp/bn"
        awk -v x="$an" -v y="$a1" -v n="$n" 'BEGIN {printf "%.5f\n", (x - y) / (n - 1)}' >>"$tmp/a"
        awk -v x="$bn" -v y="$b1" -v n="$n" 'BEGIN {printf "%.5f\n", (x - y) / (n - 1)}' >>"$tmp/b"
      done
      fastest() { sort -g "$1" | head -n 1; }
      ca=$(awk -v x="$(fastest "$tmp/an")" -v y="$(fastest "$tmp/a1")" -v n="$n" 'BEGIN {printf "%.5f", (x - y) / (n - 1)}')
      cb=$(awk -v x="$(fastest "$tmp/bn")" -v y="$(fastest "$tmp/b1")" -v n="$n" 'BEGIN {printf "%.5f", (x - y) / (n - 1)}')
      cr=$(awk -v a="$ca" -v b="$cb" 'BEGIN {printf "%.3f", b / a}')
      mr=$(awk -v a="$(median <"$tmp/a")" -v b="$(median <"$tmp/b")" 'BEGIN {printf "%.3f", b / a}')
    fi
    echo "| $scene | $algorithm | $ia | $ib | $ir | $ca | $cb | $cr | $mr |"
  done
done
