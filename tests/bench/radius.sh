#!/usr/bin/env bash
# A merge radius per pixel against the global one (docs/BENCHMARKS.md, "Per-pixel merge
# radius").
#
#     bash tests/bench/radius.sh [BUILD_DIR] [ITERATIONS] [REPEATS] [WxH]   defaults: build 64 3 320x180
#
# Every scene of the list (default: corridor, a long hallway whose visible surfaces lie
# from 1 to 24 away, and cornell-bulb, whose light reaches the room only through glass):
# vcm and upg with the global radius and with --radius per-pixel, ITERATIONS iterations,
# REPEATS times with different seeds, against a long vcm reference per scene (neither
# scene's caustics seen in a mirror can be sampled by bpt; reference_lib.sh caches it).
# Measured per run: the relative RMSE after the iterations (the reference's own noise
# removed, as convergence_report.py does) and the CPU seconds per iteration (the film's
# cpu_seconds). Errors at a fixed iteration count do not depend on the machine's load;
# the CPU per iteration does, less than wall time, and the four runs of a repeat run back
# to back. Efficiency = 1 / (relative MSE x CPU seconds), the inverse of the CPU a run
# needs for a given error (both fall as 1 / N); the table gives medians over the repeats
# and each run's efficiency over the global radius's.
set -euo pipefail
build=${1:-build}
iterations=${2:-64}
repeats=${3:-3}
size=${4:-320x180}
build=$(cd "$build" && pwd)
here=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
vcmfarm=$build/vcmfarm
source "$here/reference_lib.sh"
out=$build/bench/radius
cache=$build/bench/cache
mkdir -p "$out" "$cache"
scenes=${SCENES:-"corridor cornell-bulb"}
runs=${RUNS:-"vcm vcm_pixel upg upg_pixel"}
ref_s=${REF_SECONDS:-300}

for scene in $scenes; do
  ref=$(cached_reference "$vcmfarm" "$cache" "$scene" vcm "$ref_s" "$size" -R "$size")
  for r in $(seq 1 "$repeats"); do
    for run in $runs; do
      case $run in
      *_pixel) args=(-a "${run%_pixel}" --radius per-pixel) ;;
      *) args=(-a "$run") ;;
      esac
      film=$out/$scene-$run-$r.exr
      echo "  $scene: $run, $iterations iterations, repeat $r" >&2
      "$vcmfarm" render "$scene" "${args[@]}" -R "$size" -s $((r * 100)) -n "$iterations" -q -o "$film"
      "$vcmfarm" errors "$film" "$ref" --json >"$film.errors.json"
      "$vcmfarm" info --json "$film" >"$film.info.json"
    done
  done
  "$vcmfarm" info --json "$ref" >"$out/$scene-reference.info.json"
done
python3 - "$out" "$repeats" "$scenes" "$runs" <<'PY'
import json, math, statistics, sys
out, repeats, scenes, runs = sys.argv[1], int(sys.argv[2]), sys.argv[3].split(), sys.argv[4].split()
print("| scene | run | iterations | relative RMSE | CPU s / iteration | efficiency vs global |")
print("|---|---|---|---|---|---|")
for scene in scenes:
    ref = json.load(open(f"{out}/{scene}-reference.info.json"))
    noise, mean = ref["estimated_rmse"] or 0.0, ref["image_mean"]
    eff = {}
    rows = []
    for run in runs:
        errs, cpus, n = [], [], 0
        for r in range(1, repeats + 1):
            f = f"{out}/{scene}-{run}-{r}.exr"
            e = json.load(open(f + ".errors.json"))
            i = json.load(open(f + ".info.json"))
            rmse = e["rmse"]["all"]
            errs.append(math.sqrt(max(rmse ** 2 - noise ** 2, 0.0)) / mean)
            n = i["iteration_count"]
            cpus.append(i["cpu_seconds"] / n)
        rel, cpu = statistics.median(errs), statistics.median(cpus)
        eff[run] = 1.0 / (rel * rel * cpu)
        rows.append((run, n, rel, cpu))
    for run, n, rel, cpu in rows:
        base = eff.get(run.replace("_pixel", ""))
        ratio = "%.2f" % (eff[run] / base) if base else "-"
        print(f"| {scene} | {run} | {n} | {rel:.4f} | {cpu:.3f} | {ratio} |")
PY
