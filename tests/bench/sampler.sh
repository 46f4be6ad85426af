#!/usr/bin/env bash
# Samplers side by side (issue 21, docs/BENCHMARKS.md "Samplers"):
#
#     bash tests/bench/sampler.sh [BUILD_DIR] [REPEATS]
#
# For cornell, cornell-diffuse, cornell-glossy and cornell-bulb at 64 x 64 and for pt, bpt
# and vcm, renders ITERATIONS iterations with each sampler (`render --direct -j 1`, the
# render loop alone on one thread), REPEATS times with different seeds, the two samplers
# interleaved run by run so that a change in the machine's load touches both alike. Each
# film's convergence log holds its error against the scene's reference at many iteration
# counts. sampler_report.py then prints the tables: per-iteration CPU cost, iterations
# and CPU time to relative-RMSE targets, and the fitted slope of error against iterations,
# as medians over the repeats.
#
# References are long runs of an algorithm of another family where one exists (bpt; bpm
# for cornell-bulb, see convergence.sh) with another seed, cached in BUILD_DIR/bench/sampler/;
# their own noise (the film's estimate) is subtracted from every error. They use the sobol
# sampler: 150 s of independent bpt left a noise of 1.3% (cornell-diffuse) to 5.5%
# (cornell-bulb) of the mean, at or above the targets measured, which made the corrected
# errors there fragile; with sobol numbers the same time leaves several times less. Its
# estimate is the replicates' spread (docs/FILM.md), and independent runs converging to
# the same reference (the tables' independent slopes near -0.5) say it is not biased.
set -euo pipefail
build=${1:-build}
repeats=${2:-3}
build=$(cd "$build" && pwd)
here=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
vcmfarm=$build/vcmfarm
out=$build/bench/sampler
mkdir -p "$out"
res=64
radius=$(awk -v r="$res" 'BEGIN { printf "%.6g", 0.003 * 512 / r }')
scenes=${SCENES:-"cornell-diffuse cornell cornell-glossy cornell-bulb"}
algorithms=${ALGORITHMS:-"pt bpt vcm"}
iterations=${ITERATIONS:-2048}
ref_s=${REF_SECONDS:-100}
common=(--direct -j 1 -R "${res}x${res}" -r "$radius" -q)
for scene in $scenes; do
  ref=$out/ref-$scene.exr
  ralgo=bpt; [ "$scene" = cornell-bulb ] && ralgo=bpm
  rs=$ref_s; [ "$scene" = cornell-bulb ] && rs=$((3 * ref_s / 2))
  [ -f "$ref" ] || "$vcmfarm" render "$scene" "${common[@]}" -a $ralgo -s 99 --sampler sobol -t "$rs" -o "$ref"
done
# FIRST_REPEAT=k with REPEATS=k runs repeat k alone (two such runs side by side fill two
# cores; the report then reads repeats 1..k).
for rep in $(seq "${FIRST_REPEAT:-1}" "$repeats"); do
  for scene in $scenes; do
    for algo in $algorithms; do
      for sampler in independent sobol; do
        "$vcmfarm" render "$scene" "${common[@]}" -a "$algo" -s $((rep * 1000 + 1)) --sampler $sampler \
          -n "$iterations" --reference "$out/ref-$scene.exr" --checkpoint-interval 0.1 \
          -o "$out/$scene-$algo-$sampler-$rep.exr"
      done
    done
  done
done
[ "${FIRST_REPEAT:-1}" = 1 ] || exit 0
# docs/plots/sampler-SCENE.png: error against iterations of the first repeat's films.
root=$(cd "$here/../.." && pwd)
for scene in $scenes; do
  films=()
  for algo in $algorithms; do films+=("$out/$scene-$algo-independent-1.exr" "$out/$scene-$algo-sobol-1.exr"); done
  "$vcmfarm" plot "${films[@]}" --x iterations -o "$root/docs/plots/sampler-$scene.png"
done
python3 "$here/sampler_report.py" "$vcmfarm" "$out" "$scenes" "$algorithms" "$repeats"
