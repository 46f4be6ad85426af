#!/bin/bash
# Peak memory and time per iteration of vcm on a worker (docs/BENCHMARKS.md, "Memory"): a
# coordinator and one worker process (2 threads), each under /usr/bin/time -v, and a job of
# N iterations of SCENE at SIZE with --vcm-stages STAGES --light-path-pixels PIXELS
# submitted and waited for. Prints the worker's and the coordinator's peak resident set
# (MiB), the worker's time per iteration (the job film's render time over N: the render
# loop's own time, without the scene's loading or the shipping) and its CPU time (user +
# system, all threads, over N: the whole process). The job's film is read from the
# coordinator's state directory, written when the job completes (no client holds a copy).
#
#   bash tests/bench/worker_memory.sh BUILD SCENE SIZE N STAGES PIXELS
set -u
build=${1:?usage: worker_memory.sh BUILD SCENE SIZE N STAGES PIXELS}
scene=$2 size=$3 n=$4 stages=$5 pixels=$6
vcmfarm=$(cd "$build" && pwd)/vcmfarm
here=$(cd "$(dirname "$0")" && pwd)
source "$here/farm_lib.sh"
farm_setup worker-memory
# On any exit, the processes under /usr/bin/time too (farm_cleanup kills time alone).
trap 'for p in "${pids[@]}"; do pkill -KILL -P "$p" 2>/dev/null; done; farm_cleanup' EXIT

peak() { awk -F': ' '/Maximum resident set size/ {printf "%.0f", $2 / 1024}' "$1"; } # MiB

/usr/bin/time -v -o "$tmp/coord.time" "$vcmfarm" coordinator --listen "$url" --state "$tmp/state" \
  --secret "$tmp/key" 2>"$tmp/coord.log" &
cpid=$!
pids+=($cpid)
sleep 0.5
/usr/bin/time -v -o "$tmp/worker.time" "$vcmfarm" worker --connect "$url" --secret "$tmp/key" --threads 2 \
  --cache "$tmp/cache" 2>"$tmp/worker.log" &
wpid=$!
pids+=($wpid)
CLIENT_TIMEOUT=60 client submit "$scene" -R "$size" -n "$n" --vcm-stages "$stages" --light-path-pixels "$pixels" \
  >"$tmp/submit.out" 2>&1 || { cat "$tmp/submit.out" "$tmp/worker.log" >&2; exit 1; }
# Until the job has ended (a busy coordinator may not answer at once: asked again).
while :; do
  sleep 5
  state=$(CLIENT_TIMEOUT=30 client status 1 --json 2>/dev/null | python3 -c 'import json, sys; print(json.load(sys.stdin)["jobs"][0]["state"])' 2>/dev/null)
  case "$state" in done) break ;; failed | cancelled) cat "$tmp/coord.log" "$tmp/worker.log" >&2; exit 1 ;; esac
done
# /usr/bin/time passes no signal on: its child (by parent id) is told to stop, then time
# writes its figures and ends.
pkill -TERM -P "$wpid"; wait "$wpid" 2>/dev/null
pkill -TERM -P "$cpid"; wait "$cpid" 2>/dev/null
film=$(find "$tmp/state" -name '*.exr' | head -1)
seconds=$("$vcmfarm" info "$film" | awk '$1 == "render_seconds" {print $2}')
cpu=$(awk -F': ' -v n="$n" '/User time|System time/ {t += $2} END {printf "%.1f", t / n}' "$tmp/worker.time")
spi=$(awk -v s="$seconds" -v n="$n" 'BEGIN {printf "%.1f", s / n}')
echo "| $(basename "$scene") | $size | $stages | $pixels | $n | $(peak "$tmp/worker.time") | $(peak "$tmp/coord.time") | $spi | $cpu |"
