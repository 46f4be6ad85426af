#!/usr/bin/env bash
# CPU seconds to a relative RMSE target against a reference film, each algorithm without
# and with a pilot (docs/BENCHMARKS.md, "Participating media"):
#
#     bash tests/bench/target_time.sh BUILD_DIR SCENE REFERENCE TARGET ["ALGORITHMS"] ["PILOTS"] ["SEEDS"] [RES]
#     defaults: "pt bpt vcm" "0 8" "1 2 3" 128
#
# Each run is `render --direct -j 1 --reference REFERENCE --target-rmse T`: it stops at the
# first checkpoint (every 0.1 s) whose RMSE against the reference is at most T, and the
# film's CPU seconds, which include the pilot's, are the time to the target. T is the
# target times the reference's image mean, with the reference's own estimated RMSE added in
# quadrature (independent noise adds so), so that the target is the film's error against
# the truth; the reference should still be quieter than the target (both are printed).
# Prints the median over the seeds per algorithm and pilot, the iterations, the gain of
# each over pt without a pilot, and auto's (when run) against the best fixed algorithm's.
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
rmse=$(awk -v t="$target" -v m="$mean" -v n="$noise" 'BEGIN { printf "%.6g", sqrt((t * m)^2 + n^2) }')
echo "target_time.sh: $scene ${res}x${res}, relative RMSE $target (RMSE $rmse against the reference), reference" \
  "mean $mean, its estimated RMSE $noise; $(lscpu | sed -n 's/^Model name: *//p')"
rows=$out/rows-$scene-$target.txt # one file a scene and target: runs of several may go side by side
: >"$rows"
# Seeds outermost: every configuration runs once a round, so that a drift of the machine's
# speed (this one's CPU seconds for the same film have varied by a third over minutes)
# spreads over all of them instead of falling on the last ones.
for seed in $seeds; do
  for a in $algorithms; do
    for p in $pilots; do
      extra=()
      [ "$p" != 0 ] && extra=(--pilot "$p")
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
cpus = {}
for (a, p), v in runs.items():
    cpu = cpus[(a, p)] = statistics.median(c for c, _ in v)
    print("| %s | %s | %.2f | %d | %.2f |" % (a, p, cpu, statistics.median(i for _, i in v), base / cpu))
fixed = {k: c for k, c in cpus.items() if not k[0].startswith("auto")}
if fixed:
    best = min(fixed, key=fixed.get)
    for (a, p), c in cpus.items():
        if a.startswith("auto"):
            print("%s pilot %s: %.2f CPU s, the best fixed algorithm (%s pilot %s) %.2f: %.2f of its time"
                  % (a, p, c, best[0], best[1], fixed[best], c / fixed[best]))
EOF
