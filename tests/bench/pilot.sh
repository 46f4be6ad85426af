#!/usr/bin/env bash
# Camera sub-paths allocated per pixel from a pilot (--pilot, common/allocation.h) against
# one a pixel (docs/BENCHMARKS.md, "Camera sub-paths per pixel").
#
#     bash tests/bench/pilot.sh [BUILD_DIR] [ITERATIONS] [SEEDS] [PILOT]   defaults: build 128 "1 2 3" 16
#
# Every scene of the list at 128x128, pt, bpt and vcm without and with a pilot, for
# ITERATIONS iterations on one thread (`render --direct -j 1`; the pilot's iterations come
# on top, and its time is in the film's), each seed. Per run: the film's CPU seconds and its
# relative RMSE against the long bpt reference convergence.sh makes and caches
# (reference_lib.sh; the reference's own noise removed), and the efficiency 1 / (CPU s x
# relative MSE): where the error falls as N^-1/2 the CPU seconds to reach any error are
# inversely proportional to it. Prints medians over the seeds and each pilot's gain over
# the same algorithm without one, and the allocations' mean camera sub-paths a pixel.
# REFERENCE=FILM (one scene in SCENES) measures against that film instead: for a scene
# whose 150 s reference is too noisy for the errors measured (cornell-fog's).
set -euo pipefail
build=${1:-build}
iterations=${2:-128}
seeds=${3:-"1 2 3"}
pilot=${4:-16}
build=$(cd "$build" && pwd)
here=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
vcmfarm=$build/vcmfarm
source "$here/reference_lib.sh"
out=${OUT:-$build/bench/pilot} # films and rows; OUT for runs side by side
cache=$build/bench/cache
mkdir -p "$out" "$cache"
scenes=${SCENES:-"cornell cornell-diffuse cornell-glossy cornell-rough cornell-bulb"}
algorithms=${ALGORITHMS:-"pt bpt vcm"}
res=128
radius=$(awk -v r="$res" 'BEGIN { printf "%.6g", 0.003 * 512 / r }')
common=(-R "${res}x${res}" -r "$radius")

echo "pilot.sh: ${res}x${res}, $iterations iterations, seeds $seeds, pilot $pilot; $(lscpu | sed -n 's/^Model name: *//p')"
rows=$out/rows.txt
: >"$rows"
for scene in $scenes; do
  ref=${REFERENCE:-$(cached_reference "$vcmfarm" "$cache" "$scene" bpt 150 "$res" "${common[@]}")} # convergence.sh's too
  for a in $algorithms; do
    for p in 0 "$pilot"; do
      for seed in $seeds; do
        film=$out/$(basename "$scene")-$a-$p-$seed.exr
        extra=()
        [ "$p" != 0 ] && extra=(--pilot "$p")
        "$vcmfarm" render "$scene" --direct -a "$a" -n "$iterations" -j 1 -s "$seed" -q "${common[@]}" "${extra[@]}" \
          -o "$film"
        python3 - "$vcmfarm" "$film" "$ref" "$scene" "$a" "$p" "$seed" >>"$rows" <<'EOF'
import json, math, subprocess, sys
vcmfarm, film, ref, scene, a, p, seed = sys.argv[1:8]
e = json.loads(subprocess.check_output([vcmfarm, "errors", film, ref, "--json"]))
info = json.loads(subprocess.check_output([vcmfarm, "info", film, "--json"]))
noise = json.loads(subprocess.check_output([vcmfarm, "info", ref, "--json"])).get("estimated_rmse") or 0.0
rel = math.sqrt(max(e["rmse"]["all"] ** 2 - noise ** 2, 0.0)) / e["mean_reference"]
mean_k = info.get("allocation", {}).get("mean_camera_sub_paths", 1.0)
print(scene, a, p, seed, info["cpu_seconds"], rel, mean_k)
EOF
      done
    done
  done
done
python3 - "$rows" "$pilot" <<'EOF' | tee "$out/report.md"
import statistics, sys
rows = [l.split() for l in open(sys.argv[1])]
pilot = sys.argv[2]
runs = {}
for scene, a, p, seed, cpu, rel, k in rows:
    runs.setdefault((scene, a, p), []).append((float(cpu), float(rel), float(k)))
def med(v): return statistics.median(v)
print("| scene | algorithm | CPU s | rel. RMSE | efficiency | with pilot %s: CPU s | rel. RMSE | efficiency | camera sub-paths a pixel | gain |" % pilot)
print("|---|---|---|---|---|---|---|---|---|---|")
for (scene, a, p) in runs:
    if p != "0": continue
    base, pil = runs[(scene, a, "0")], runs.get((scene, a, pilot), [])
    eb = med([1 / (c * r * r) for c, r, _ in base])
    ep = med([1 / (c * r * r) for c, r, _ in pil]) if pil else float("nan")
    print("| %s | %s | %.2f | %.4f | %.0f | %.2f | %.4f | %.0f | %.2f | %.2f |" % (
        scene, a, med([c for c, _, _ in base]), med([r for _, r, _ in base]), eb,
        med([c for c, _, _ in pil]), med([r for _, r, _ in pil]), ep, med([k for _, _, k in pil]), ep / eb))
EOF
