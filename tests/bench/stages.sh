#!/bin/bash
# Single-stage against two-stage vcm (--vcm-stages 1|2, docs/BENCHMARKS.md "Memory"): peak
# resident memory (/usr/bin/time -v) and time per iteration of `vcmfarm render SCENE -R SIZE
# -n N` (2 threads), the two alternated run by run, ROUNDS rounds; medians. Time per
# iteration: the render's own "after the first iteration" rate (steady: without the first,
# whose single-stage run also traces the light sub-paths of the iteration before) and the
# first iteration's seconds (all iterations' time less the steady ones'); the process's CPU
# time (user + system, all threads) over N, which a shared host's load moves far less than
# wall time (a single-stage run's includes its second light pass); and the render's
# split of an iteration's time between light sub-paths, grid and camera sub-paths (ms, mean
# over the run's iterations; single-stage: the light share of its fused pass, and the
# first iteration's second light pass).
#
#   bash tests/bench/stages.sh BUILD SCENE SIZE N ROUNDS      # e.g. build cornell 1920x1080 3 3
set -u
build=${1:?usage: stages.sh BUILD SCENE SIZE N ROUNDS}
scene=$2 size=$3 n=$4 rounds=$5
vcmfarm=$(cd "$build" && pwd)/vcmfarm
tmp=$(mktemp -d /tmp/vf-stages-XXXXXX)
trap 'rm -rf "$tmp"' EXIT
median() { sort -g | awk '{v[NR] = $1} END {print NR % 2 ? v[(NR + 1) / 2] : (v[NR / 2] + v[NR / 2 + 1]) / 2}'; }
for r in $(seq "$rounds"); do
  order="1 2"
  [ $((r % 2)) -eq 0 ] && order="2 1"
  for s in $order; do
    /usr/bin/time -v "$vcmfarm" render "$scene" -R "$size" -n "$n" -j 2 --vcm-stages "$s" -o "$tmp/f.exr" \
      >"$tmp/out" 2>"$tmp/err" || { cat "$tmp/err"; exit 1; }
    rss=$(awk -F': ' '/Maximum resident set size/ {printf "%.0f", $2 / 1024}' "$tmp/err")
    total=$(sed -n 's/^rendered [0-9]* iterations* .* in \([0-9.]*\) s:.*/\1/p' "$tmp/err" "$tmp/out" | head -1)
    steady=$(sed -n 's/^after the first iteration: \([0-9.]*\) it\/s.*/\1/p' "$tmp/err" "$tmp/out" | head -1)
    first=$(awk -v t="$total" -v s="${steady:-0}" -v n="$n" 'BEGIN {print (s > 0 ? t - (n - 1) / s : t)}')
    phases=$(sed -n 's/^per iteration: light sub-paths \([0-9.]*\) ms, grid \([0-9.]*\) ms, camera sub-paths \([0-9.]*\) ms.*/\1 \2 \3/p' \
      "$tmp/err" "$tmp/out" | head -1)
    cpu=$(awk -F': ' -v n="$n" '/User time|System time/ {t += $2} END {print t / n}' "$tmp/err")
    echo "$s $rss ${steady:-nan} $first ${phases:-nan nan nan} $cpu" >>"$tmp/runs"
    echo "  round $r, stages $s: $rss MiB, steady ${steady:-?} it/s, first iteration $first s, ms $phases," \
      "CPU $cpu s/it" >&2
  done
done
echo "| scene | size | stages | peak MiB | steady s/it | first iteration s | CPU s/it | light / grid / camera ms | runs |"
echo "|---|---|---|---|---|---|---|---|---|"
for s in 2 1; do
  rss=$(awk -v s=$s '$1 == s {print $2}' "$tmp/runs" | median)
  spi=$(awk -v s=$s '$1 == s && $3 > 0 {print 1 / $3}' "$tmp/runs" | median)
  first=$(awk -v s=$s '$1 == s {print $4}' "$tmp/runs" | median)
  light=$(awk -v s=$s '$1 == s {print $5}' "$tmp/runs" | median)
  grid=$(awk -v s=$s '$1 == s {print $6}' "$tmp/runs" | median)
  camera=$(awk -v s=$s '$1 == s {print $7}' "$tmp/runs" | median)
  cpu=$(awk -v s=$s '$1 == s {print $8}' "$tmp/runs" | median)
  printf "| %s | %s | %s | %s | %.2f | %.2f | %.2f | %.0f / %.0f / %.0f | %s |\n" "$scene" "$size" "$s" "$rss" \
    "${spi:-0}" "$first" "$cpu" "$light" "$grid" "$camera" "$rounds"
done
