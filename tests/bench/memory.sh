#!/bin/bash
# Peak memory (maximum resident set, /usr/bin/time -v) of the ways to render, for
# docs/BENCHMARKS.md ("Memory"): `render --direct`, `render` (the same render since render
# lost its in-process farm; on older builds, the in-process farm) and a worker process
# (with a coordinator process beside it, whose peak is printed too), vcm with default
# settings on cornell, N iterations at each size.
#
#   bash tests/bench/memory.sh BUILD [N] [SIZES...]     # default 2 iterations, 1920x1080 3840x2160
set -u
build=${1:?usage: memory.sh BUILD [N] [SIZES...]}
n=${2:-2}
shift 2 2>/dev/null || shift $#
sizes=("$@")
[ ${#sizes[@]} -eq 0 ] && sizes=(1920x1080 3840x2160)
vcmfarm=$(cd "$build" && pwd)/vcmfarm
here=$(cd "$(dirname "$0")" && pwd)
source "$here/farm_lib.sh"
farm_setup memory

peak() { awk -F': ' '/Maximum resident set size/ {printf "%.0f", $2 / 1024}' "$1"; } # MiB

echo "| size | render --direct MiB | render MiB | worker MiB | coordinator MiB | it/s (--direct) |"
echo "|---|---|---|---|---|---|"
for size in "${sizes[@]}"; do
  /usr/bin/time -v "$vcmfarm" render cornell --direct -R "$size" -n "$n" -o "$tmp/direct.exr" \
    >"$tmp/direct.out" 2>"$tmp/direct.time" || { cat "$tmp/direct.time"; exit 1; }
  rate=$(grep -o '[0-9.]* it/s' "$tmp/direct.out" "$tmp/direct.time" | head -1 | awk -F: '{print $NF}')
  /usr/bin/time -v "$vcmfarm" render cornell -R "$size" -n "$n" -o "$tmp/farm.exr" \
    >"$tmp/farm.out" 2>"$tmp/farm.time" || { cat "$tmp/farm.time"; exit 1; }
  rm -rf "$tmp/state"
  /usr/bin/time -v -o "$tmp/coord.time" "$vcmfarm" coordinator --listen "$url" --state "$tmp/state" \
    --secret "$tmp/key" 2>"$tmp/coord.log" &
  pids+=($!)
  sleep 0.5
  /usr/bin/time -v -o "$tmp/worker.time" "$vcmfarm" worker --connect "$url" --secret "$tmp/key" \
    --cache "$tmp/cache" 2>"$tmp/worker.log" &
  wpid=$!
  pids+=($wpid)
  client submit cornell -R "$size" -n "$n" --wait -o "$tmp/submit.exr" >/dev/null 2>&1 ||
    CLIENT_TIMEOUT=60 client submit cornell -R "$size" -n "$n" --wait -o "$tmp/submit.exr" >/dev/null
  # /usr/bin/time passes no signal on: its child (by parent id) is told to stop, then time
  # writes its figures and ends.
  pkill -TERM -P "$wpid"; wait "$wpid" 2>/dev/null
  pkill -TERM -P "${pids[-2]}"; wait "${pids[-2]}" 2>/dev/null
  echo "| $size | $(peak "$tmp/direct.time") | $(peak "$tmp/farm.time") | $(peak "$tmp/worker.time") | $(peak "$tmp/coord.time") | $rate |"
done
