#!/usr/bin/env bash
# Whether two builds render the same films bit for bit: every algorithm, both samplers,
# each scene given (default: the Cornell members a renderer change is checked on), 4
# iterations at 64x64, seed 7; farm_compare --exact on each pair. For changes meant to
# leave every number as it was (a faster kernel, a skipped computation). Prints one line
# per film and the count of those that differ; exits 1 if any does.
#
#   [SCENES="cornell cornell-glossy ..."] [ALGORITHMS="pt bpt ..."] tests/bench/same_films.sh BUILD_A BUILD_B
set -euo pipefail
if [ $# -lt 2 ]; then
  echo "usage: [SCENES=...] [ALGORITHMS=...] $0 BUILD_A BUILD_B" >&2
  exit 2
fi
a="$1" b="$2"
scenes="${SCENES:-cornell cornell-glossy cornell-env cornell-rough cornell-fog}"
algorithms="${ALGORITHMS:-pt bpt vcm lt ppm bpm upg}"
compare="$b/tests/farm/farm_compare"
[ -x "$compare" ] || compare="$a/tests/farm/farm_compare"
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
differ=0
for scene in $scenes; do
  for algorithm in $algorithms; do
    for sampler in sobol independent; do
      for k in 0 1; do
        build=$a && [ $k = 1 ] && build=$b
        "$build/vcmfarm" render "$scene" --direct -a "$algorithm" -n 4 -R 64x64 -s 7 --sampler "$sampler" -j 2 \
          -o "$tmp/$k.exr" >"$tmp/log$k" 2>&1 || { echo "$scene $algorithm $sampler: render failed"; cat "$tmp/log$k"; exit 1; }
      done
      if "$compare" --exact "$tmp/0.exr" "$tmp/1.exr" '[0,4)' >"$tmp/cmp" 2>&1; then
        echo "$scene $algorithm $sampler: same"
      else
        echo "$scene $algorithm $sampler: DIFFERENT ($(tail -n 1 "$tmp/cmp"))"
        differ=$((differ + 1))
      fi
    done
  done
done
echo "$differ films differ"
[ "$differ" = 0 ]
