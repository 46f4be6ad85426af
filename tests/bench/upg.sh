#!/usr/bin/env bash
# Unbiased photon gathering against vcm, bpt and pt (docs/BENCHMARKS.md, "Unbiased photon
# gathering").
#
#     bash tests/bench/upg.sh [BUILD_DIR] [SECONDS]      defaults: build 20
#
# 1. Every scene of the list at 128x128 for SECONDS of wall time per run (`render` with
# --reference and checkpoints): upg gathering from the light's side, from the camera's
# (upg_camera), vcm, bpt and pt (and with RUNS, upg_auto: --gather-from auto), against the long bpt references convergence.sh makes and
# caches (reference_lib.sh, BUILD_DIR/bench/cache). Reported by convergence_report.py
# (time to relative-RMSE targets, slopes) into BUILD_DIR/bench/upg/report.md, then per
# scene and run what an iteration costs and where its time goes (the render's summary
# lines), and upg's tentative directions and rays per gathering.
# 2. Merging bias with a fixed radius: cornell-diffuse at 64x64, radius factor 0.05 and
#    alpha 1, 1024 iterations of vcm and of upg from each side, against the bpt reference
#    of 4096 iterations mis_beta.sh caches, in 8x8 blocks (build/tests/block_means).
set -euo pipefail
build=${1:-build}
seconds=${2:-20}
build=$(cd "$build" && pwd)
here=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
vcmfarm=$build/vcmfarm
source "$here/reference_lib.sh"
out=$build/bench/upg
cache=$build/bench/cache
mkdir -p "$out" "$cache"
scenes=${SCENES:-"cornell cornell-diffuse cornell-glossy cornell-rough cornell-bulb"}
runs=${RUNS:-"upg upg_camera vcm bpt pt"}
res=128
ref_s=150
radius=$(awk -v r="$res" 'BEGIN { printf "%.6g", 0.003 * 512 / r }')
common=(-R "${res}x${res}" -r "$radius")

for scene in $scenes; do
  ref=$(cached_reference "$vcmfarm" "$cache" "$scene" bpt "$ref_s" "$res" "${common[@]}") # convergence.sh's too
  ln -sf "$ref" "$out/$scene-reference.exr"
  for run in $runs; do
    case $run in
    upg_camera) args=(-a upg --gather-from camera) ;;
    upg_auto) args=(-a upg --gather-from auto) ;;
    *) args=(-a "$run") ;;
    esac
    echo "  $scene: $run for $seconds s"
    "$vcmfarm" render "$scene" "${args[@]}" -t "$seconds" --checkpoint-interval 0.5 --reference "$ref" \
      "${common[@]}" -v -o "$out/$scene-$run.exr" 2>"$out/$scene-$run.log"
  done
done
python3 "$here/convergence_report.py" "$vcmfarm" "$out" full "$scenes" "$runs" | tee "$out/report.md"

echo
echo "Per iteration (ms: light sub-paths, grid, camera sub-paths with merging or gathering) and upg's gatherings:"
echo
echo "| scene | run | it/s | light | grid | camera | gatherings/it | directions each | rays each | merged as vcm/it |"
echo "|---|---|---|---|---|---|---|---|---|---|"
for scene in $scenes; do
  for run in $runs; do
    log=$out/$scene-$run.log
    python3 - "$log" "$scene" "$run" <<'EOF'
import re, sys
log, scene, run = sys.argv[1:4]
text = open(log).read()
it = re.search(r"rendered (\d+) iterations? \S+ in [\d.]+ s: ([\d.]+) it/s", text)
phases = re.search(r"per iteration: light sub-paths ([\d.]+) ms, grid ([\d.]+) ms, camera sub-paths ([\d.]+) ms", text)
g = re.search(r"gathering: (\d+) light vertices without bias, ([\d.]+) tentative directions and ([\d.]+) rays each; (\d+) merged", text)
n = int(it.group(1)) if it else 0
cells = [scene, run, it.group(2) if it else "-"] + (list(phases.groups()) if phases else ["-"] * 3)
if g and n:
    cells += ["%.0f" % (int(g.group(1)) / n), g.group(2), g.group(3), "%.1f" % (int(g.group(4)) / n)]
else:
    cells += ["-"] * 4
print("| " + " | ".join(cells) + " |")
EOF
  done
done | tee -a "$out/report.md"

echo
echo "Merging bias with a fixed radius (cornell-diffuse 64x64, radius factor 0.05, alpha 1, 1024 iterations):"
fixed=(-R 64x64 -r 0.05 --alpha 1)
bias_ref=$cache/bias-ref-cornell-diffuse-64-bpt-4096.exr # mis_beta.sh's too
[ -f "$bias_ref" ] || "$vcmfarm" render cornell-diffuse -a bpt -s 2000 -n 4096 "${fixed[@]}" -q -o "$bias_ref"
"$vcmfarm" render cornell-diffuse -a vcm -n 1024 "${fixed[@]}" -q -o "$out/bias-vcm.exr"
for side in light camera; do
  "$vcmfarm" render cornell-diffuse -a upg --gather-from $side -n 1024 "${fixed[@]}" -q -o "$out/bias-upg-$side.exr"
done
"$build/tests/block_means" "$bias_ref" "$out/bias-vcm.exr" "$out/bias-upg-light.exr" "$out/bias-upg-camera.exr" |
  tee "$out/bias.txt"
