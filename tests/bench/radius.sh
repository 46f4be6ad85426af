#!/usr/bin/env bash
# A merge radius per pixel against the global one (docs/BENCHMARKS.md, "Per-pixel merge
# radius").
#
#     bash tests/bench/radius.sh [BUILD_DIR] [SECONDS] [REPEATS]      defaults: build 20 3
#
# Every scene of the list (default: corridor, a long hallway whose visible surfaces lie
# from 1 to 24 away, and cornell-bulb, whose light reaches the room only through glass)
# at 320x180 for SECONDS of wall time per run: vcm and upg with the global radius and with
# --radius per-pixel, REPEATS times with different seeds, against long vcm references
# (reference_lib.sh: neither scene's caustics seen in a mirror can be sampled by bpt).
# Reported by convergence_report.py per repeat into BUILD_DIR/bench/radius/rN/report.md,
# then the median over the repeats of each run's time to the targets and its iteration rate.
set -euo pipefail
build=${1:-build}
seconds=${2:-20}
repeats=${3:-3}
build=$(cd "$build" && pwd)
here=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
vcmfarm=$build/vcmfarm
source "$here/reference_lib.sh"
out=$build/bench/radius
cache=$build/bench/cache
mkdir -p "$out" "$cache"
scenes=${SCENES:-"corridor cornell-bulb"}
runs=${RUNS:-"vcm vcm_pixel upg upg_pixel"}
ref_s=${REF_SECONDS:-200}
common=(-R 320x180)

for scene in $scenes; do
  ref=$(cached_reference "$vcmfarm" "$cache" "$scene" vcm "$ref_s" 320x180 "${common[@]}")
  for r in $(seq 1 "$repeats"); do
    dir=$out/r$r
    mkdir -p "$dir"
    ln -sf "$ref" "$dir/$scene-reference.exr"
    for run in $runs; do
      case $run in
      *_pixel) args=(-a "${run%_pixel}" --radius per-pixel) ;;
      *) args=(-a "$run") ;;
      esac
      echo "  $scene: $run for $seconds s, repeat $r" >&2
      "$vcmfarm" render "$scene" "${args[@]}" -s $((r * 100)) -t "$seconds" --checkpoint-interval 0.5 \
        --reference "$ref" "${common[@]}" -v -o "$dir/$scene-$run.exr" 2>"$dir/$scene-$run.log"
    done
  done
done
for r in $(seq 1 "$repeats"); do
  python3 "$here/convergence_report.py" "$vcmfarm" "$out/r$r" full "$scenes" "$runs" >"$out/r$r/report.md"
done
python3 - "$out" "$repeats" "$scenes" "$runs" <<'PY'
import re, statistics, sys
out, repeats, scenes, runs = sys.argv[1], int(sys.argv[2]), sys.argv[3].split(), sys.argv[4].split()
rows = {}
for r in range(1, repeats + 1):
    for line in open(f"{out}/r{r}/report.md"):
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if len(cells) >= 6 and cells[0] in scenes and cells[1] in runs:
            rows.setdefault((cells[0], cells[1]), []).append(cells)
print("| scene | run | it/s | final rel. RMSE | time to 0.2 | to 0.1 | to 0.05 |")
print("|---|---|---|---|---|---|---|")
def med(values):
    nums = [float(v.rstrip("s")) for v in values if re.match(r"^[\d.]+s?$", v)]
    return "%.3g" % statistics.median(nums) if len(nums) == len(values) and nums else "-"
for scene in scenes:
    for run in runs:
        cs = rows.get((scene, run), [])
        if not cs:
            continue
        cols = list(zip(*cs))
        # convergence_report.py's columns: it/s 2, final relative RMSE 4, times to 0.2, 0.1, 0.05 at 7-9.
        print("| " + " | ".join([scene, run] + [med(cols[i]) for i in (2, 4, 7, 8, 9)]) + " |")
PY
