#!/usr/bin/env bash
# CPU seconds to a relative RMSE target against a reference film, each algorithm without
# and with a pilot (docs/BENCHMARKS.md, "Participating media"):
#
#     bash tests/bench/target_time.sh BUILD_DIR SCENE REFERENCE TARGET ["ALGORITHMS"] ["PILOTS"] ["SEEDS"] [RES]
#     defaults: "pt bpt vcm" "0 8" "1 2 3" 128
#
# Each run is `render --direct -j 1 --reference REFERENCE --target-rmse T`, T the target
# times the reference's image mean: it stops at the first checkpoint (every 0.1 s) whose
# RMSE against the reference is at most T, and the film's CPU seconds, which include the
# pilot's, are the time to the target. The reference must be much quieter than the target
# (its own estimated RMSE is printed). Prints the median over the seeds per algorithm and
# pilot, the iterations, and the gain of each over pt without a pilot.
set -euo pipefail
build=$(cd "$1" && pwd)
scene=$2 ref=$3 target=$4
algorithms=${5:-"pt bpt vcm"}
pilots=${6:-"0 8"}
seeds=${7:-"1 2 3"}
res=${8:-128}
vcmfarm=$build/vcmfarm
out=$build/bench/target_time
mkdir -p "$out"
radius=$(awk -v r="$res" 'BEGIN { printf "%.6g", 0.003 * 512 / r }') # convergence.sh's
mean=$("$vcmfarm" info --json "$ref" | jq -r .image_mean)
noise=$("$vcmfarm" info --json "$ref" | jq -r .estimated_rmse)
rmse=$(awk -v t="$target" -v m="$mean" 'BEGIN { printf "%.6g", t * m }')
echo "target_time.sh: $scene ${res}x${res}, relative RMSE $target (RMSE $rmse), reference mean $mean," \
  "its estimated RMSE $noise; $(lscpu | sed -n 's/^Model name: *//p')"
rows=$out/rows.txt
: >"$rows"
for a in $algorithms; do
  for p in $pilots; do
    extra=()
    [ "$p" != 0 ] && extra=(--pilot "$p")
    for seed in $seeds; do
      film=$out/$scene-$a-$p-$seed.exr
      "$vcmfarm" render "$scene" --direct -a "$a" -j 1 -s "$seed" -R "${res}x${res}" -r "$radius" "${extra[@]}" \
        --reference "$ref" --target-rmse "$rmse" --checkpoint-interval 0.1 -n 100000 -q -o "$film"
      "$vcmfarm" info --json "$film" |
        jq -r --arg a "$a" --arg p "$p" '[$a, $p, .cpu_seconds, .iteration_count, .convergence[-1].rmse] | @tsv' >>"$rows"
    done
  done
done
python3 - "$rows" "$rmse" <<'EOF'
import statistics, sys
rows = [l.split("\t") for l in open(sys.argv[1]).read().splitlines()]
target = float(sys.argv[2])
runs = {}
for a, p, cpu, its, rmse in rows:
    if float(rmse) > target:
        sys.exit("%s pilot %s: stopped at RMSE %s, above the target" % (a, p, rmse))
    runs.setdefault((a, p), []).append((float(cpu), int(its)))
base = statistics.median(c for c, _ in runs.get(("pt", "0"), [(float("nan"), 0)]))
print("| algorithm | pilot | CPU s to the target | iterations | pt without a pilot / this |")
print("|---|---|---|---|---|")
for (a, p), v in runs.items():
    cpu = statistics.median(c for c, _ in v)
    print("| %s | %s | %.2f | %d | %.2f |" % (a, p, cpu, statistics.median(i for _, i in v), base / cpu))
EOF
