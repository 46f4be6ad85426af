#!/usr/bin/env bash
# Should the light sub-paths of the sobol sampler be stratified across iterations, across
# the paths of an iteration, or not at all? (issue 21, docs/BENCHMARKS.md "Stratifying the
# light sub-paths"). Merging is a density estimate over all light vertices of an iteration.
#
#     bash tests/bench/light_strata.sh REF_DIR ITERATIONS BIN0 BIN1 BIN2
#
# BINm is a vcmfarm built with -DVF_LIGHT_STRATIFICATION=m (worker/render/light_pass.c: 0 across
# iterations, 1 across paths, 2 none); REF_DIR holds the references of sampler.sh. Renders
# vcm (and bpm, merging alone) on cornell, cornell-bulb and cornell-glossy with each and
# prints the relative RMSE after ITERATIONS, corrected for the reference's noise.
set -euo pipefail
refs=$1 n=$2
shift 2
res=64
radius=$(awk -v r="$res" 'BEGIN { printf "%.6g", 0.003 * 512 / r }')
for scene in cornell cornell-bulb cornell-glossy; do
  ref=$refs/ref-$scene.exr
  noise=$("$1" info --json "$ref" | jq .estimated_rmse)
  mean=$("$1" info --json "$ref" | jq .image_mean)
  for algo in vcm bpm; do
    for seed in 1001 2001; do
      line="$scene $algo seed $seed:"
      m=0
      for bin in "$@"; do
        out=/tmp/light_strata_$$.exr
        "$bin" render "$scene" --direct -j 1 -R ${res}x${res} -r "$radius" -q -a $algo -s $seed --sampler sobol \
          -n "$n" --reference "$ref" --checkpoint-interval 0 -o "$out"
        rmse=$("$bin" info --json "$out" | jq '.convergence[-1].rmse')
        line="$line  mode $m $(awk -v e="$rmse" -v z="$noise" -v m="$mean" 'BEGIN { d = e*e - z*z; printf "%.4f", (d > 0 ? sqrt(d) : 0) / m }')"
        m=$((m + 1))
        rm -f "$out"
      done
      echo "$line"
    done
  done
done
