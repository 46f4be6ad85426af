#!/usr/bin/env bash
# The MIS heuristic's exponent (docs/BENCHMARKS.md, "MIS heuristic"): the balance heuristic
# (beta 1) against the power heuristic (beta 2), for vcm and bpt.
#
#     bash tests/bench/mis_beta.sh [BUILD_DIR] [SECONDS]      defaults: build 30
#
# 1. Time to error: every scene of the list at 128x128 for SECONDS of wall time per run
#    (`render` with --reference and checkpoints), against the same long bpt references
#    convergence.sh makes and caches (reference_lib.sh, BUILD_DIR/bench/cache), reported by
#    convergence_report.py (time to relative-RMSE targets, slopes), into
#    BUILD_DIR/bench/mis_beta/report.md.
# 2. Merging bias with a fixed radius: cornell-diffuse at 64x64, vcm with radius factor
#    0.05 and alpha 1 for 1024 iterations under each beta, and bpt under beta 1, each
#    against a bpt reference of 4096 iterations, in 8x8 blocks (build/tests/block_means).
set -euo pipefail
build=${1:-build}
seconds=${2:-30}
build=$(cd "$build" && pwd)
here=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
vcmfarm=$build/vcmfarm
source "$here/reference_lib.sh"
out=$build/bench/mis_beta
cache=$build/bench/cache
mkdir -p "$out" "$cache"
scenes=${SCENES:-"cornell cornell-diffuse cornell-glossy cornell-rough knot"}
res=128
ref_s=150
radius=$(awk -v r="$res" 'BEGIN { printf "%.6g", 0.003 * 512 / r }')
common=(-R "${res}x${res}" -r "$radius")
runs="vcm-b1 vcm-b2 bpt-b1 bpt-b2"

for scene in $scenes; do
  ref=$(cached_reference "$vcmfarm" "$cache" "$scene" bpt "$ref_s" "$res" "${common[@]}") # convergence.sh's too
  ln -sf "$ref" "$out/$scene-reference.exr"
  for run in $runs; do
    echo "  $scene: $run for $seconds s"
    "$vcmfarm" render "$scene" -a "${run%-b*}" --mis-beta "${run#*-b}" -t "$seconds" --checkpoint-interval 0.5 \
      --reference "$ref" "${common[@]}" -o "$out/$scene-$run.exr" 2>"$out/$scene-$run.log"
  done
done
python3 "$here/convergence_report.py" "$vcmfarm" "$out" full "$scenes" "$runs" | tee "$out/report.md"

echo
echo "Merging bias with a fixed radius (cornell-diffuse 64x64, radius factor 0.05, alpha 1, 1024 iterations):"
fixed=(-R 64x64 -r 0.05 --alpha 1)
bias_ref=$cache/bias-ref-cornell-diffuse-64-bpt-4096.exr
[ -f "$bias_ref" ] || "$vcmfarm" render cornell-diffuse -a bpt -s 2000 -n 4096 "${fixed[@]}" -q -o "$bias_ref"
for beta in 1 2; do
  "$vcmfarm" render cornell-diffuse -a vcm --mis-beta "$beta" -n 1024 "${fixed[@]}" -q -o "$out/bias-vcm-b$beta.exr"
done
"$vcmfarm" render cornell-diffuse -a bpt -s 7 -n 1024 "${fixed[@]}" -q -o "$out/bias-bpt-b1.exr"
"$build/tests/block_means" "$bias_ref" "$out/bias-vcm-b1.exr" "$out/bias-vcm-b2.exr" "$out/bias-bpt-b1.exr" |
  tee "$out/bias.txt"
