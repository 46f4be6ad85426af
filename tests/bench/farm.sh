#!/usr/bin/env bash
# Farm throughput on this machine: one job rendered by 1 worker, then by 2 workers (one
# render thread each), against `vcmfarm render --direct -j 1` of the same iterations.
#
#   bash tests/bench/farm.sh BUILD_DIR [ITERATIONS] [RESOLUTION]     defaults: 48 256x256
#
# Times from submit to "done" (status polled every 0.1 s); workers are registered first.
set -u
build="$1"
iterations="${2:-48}"
resolution="${3:-256x256}"
vcmfarm="$build/vcmfarm"
source "$(dirname "${BASH_SOURCE[0]}")/farm_lib.sh"
farm_setup farm

start=$(date +%s.%N)
"$vcmfarm" render cornell --direct -n "$iterations" -R "$resolution" -j 1 -q -o "$tmp/local.exr" || exit 1
local_s=$(echo "$(date +%s.%N) - $start" | bc)
printf "render -j 1: %d iterations in %.2f s = %.3f it/s\n" "$iterations" "$local_s" "$(echo "$iterations / $local_s" | bc -l)"

for workers in 1 2; do
  rm -rf "$tmp/state"
  "$vcmfarm" coordinator --listen "$url" --state "$tmp/state" --secret "$tmp/key" --lease-seconds 5 \
    >"$tmp/coordinator.log" 2>&1 &
  pids+=($!)
  for w in $(seq "$workers"); do
    "$vcmfarm" worker --connect "$url" --secret "$tmp/key" --threads 1 --name "w$w" >"$tmp/w$w.log" 2>&1 &
    pids+=($!)
  done
  deadline=$((SECONDS + 600))
  until [ "$(client status --json 2>/dev/null | grep -c '"threads":')" -eq "$workers" ]; do
    [ "$SECONDS" -lt "$deadline" ] || { echo "workers did not register"; exit 1; }
    sleep 0.1
  done
  start=$(date +%s.%N)
  job=$(client submit cornell -n "$iterations" -R "$resolution" 2>/dev/null | tail -n 1)
  until client status "$job" --json 2>/dev/null | tr -d ' \t\n' | grep -q '"state":"done"'; do
    [ "$SECONDS" -lt "$deadline" ] || { echo "job $job not done in time"; exit 1; }
    sleep 0.1
  done
  s=$(echo "$(date +%s.%N) - $start" | bc)
  printf "%d worker(s) x 1 thread: %d iterations in %.2f s = %.3f it/s\n" "$workers" "$iterations" "$s" \
    "$(echo "$iterations / $s" | bc -l)"
  for p in "${pids[@]}"; do kill -TERM "$p" 2>/dev/null; done
  wait 2>/dev/null
  pids=()
done
