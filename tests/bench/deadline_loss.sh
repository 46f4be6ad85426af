#!/bin/bash
# Work lost at a job's time limit (docs/BENCHMARKS.md, "Work lost at deadlines"): a farm
# job of `--time LIMIT` (default 60) on WORKERS one-thread workers of this machine, over
# ipc://, the coordinator on default settings; the loss is the iterations the workers
# rendered (their log lines "lease ...: rendered N iterations of job J") that are not in
# the job's film (`status`: iterations_done), over those rendered.
#
#   bash tests/bench/deadline_loss.sh VCMFARM sim|real WORKERS...
#
#   sim   cornell at 32x32, every iteration followed by a 200 ms sleep
#         (--test-iteration-delay): workers that cost almost no CPU, so that 16 of them on
#         two cores behave as 16 machines would
#   real  cornell at 128x128, rendered, nothing else: 16 workers share the machine's cores
#
# Prints one line per farm: MODE WORKERS rendered film lost lost%. LIMIT=S sets the limit.
# A build before protocol 9 logs no "rendered" line: add it to its worker.c (the note after
# vf_render_range in run_lease, as in this one) to measure it.
set -u
vcmfarm=${1:?usage: deadline_loss.sh VCMFARM sim|real WORKERS...}
mode=${2:?usage: deadline_loss.sh VCMFARM sim|real WORKERS...}
shift 2
limit=${LIMIT:-60}
case "$mode" in
sim) resolution=32x32 worker_options=(--test-iteration-delay 200) ;;
real) resolution=128x128 worker_options=() ;;
*) echo "mode sim or real" >&2; exit 2 ;;
esac
field() { # json on stdin, job, field
  python3 -c '
import json, sys
try:
    j = next(j for j in json.load(sys.stdin)["jobs"] if j["id"] == int(sys.argv[1]))
    print(j[sys.argv[2]])
except Exception:
    pass' "$1" "$2"
}
for n in "$@"; do
  tmp=$(mktemp -d /tmp/vf-deadline-loss-XXXXXX)
  key="$tmp/farm.key" url="ipc://$tmp/coordinator.sock"
  "$vcmfarm" keygen "$key" >/dev/null 2>&1
  "$vcmfarm" coordinator --listen "$url" --state "$tmp/state" --secret "$key" >"$tmp/coordinator.log" 2>&1 &
  pids=($!)
  for _ in $(seq 100); do [ -S "$tmp/coordinator.sock" ] && break; sleep 0.1; done
  for i in $(seq "$n"); do
    "$vcmfarm" worker --connect "$url" --secret "$key" --threads 1 --name "w$i" "${worker_options[@]}" \
      >"$tmp/w$i.log" 2>&1 &
    pids+=($!)
  done
  client() { "$vcmfarm" "$@" --coordinator "$url" --secret "$key" --timeout 5; }
  for _ in $(seq 300); do
    [ "$(client status --json 2>/dev/null | grep -c '"threads":')" -ge "$n" ] && break
    sleep 0.1
  done
  job=$(client submit cornell -R "$resolution" --seed 7 --time "$limit" 2>/dev/null | tail -n 1)
  state=""
  for _ in $(seq $((limit + 180))); do
    state=$(client status "$job" --json 2>/dev/null | field "$job" state)
    [ "$state" = done ] || [ "$state" = failed ] && break
    sleep 1
  done
  film=$(client status "$job" --json 2>/dev/null | field "$job" iterations_done)
  seconds=$(client status "$job" --json 2>/dev/null | field "$job" seconds)
  rendered=$(cat "$tmp"/w*.log | sed -n "s/.*: rendered \([0-9]*\) iterations\{0,1\} of job $job .*/\1/p" |
    awk '{ s += $1 } END { print s + 0 }')
  for p in "${pids[@]}"; do kill -TERM "$p" 2>/dev/null; done
  wait 2>/dev/null
  awk -v m="$mode" -v n="$n" -v r="$rendered" -v f="${film:-0}" -v st="$state" -v s="${seconds:-?}" 'BEGIN {
    printf "%s %2d workers: %6d rendered, %6d in the film, %5d lost (%.2f%%); job %s after %s s\n",
      m, n, r, f, r - f, (r > 0 ? 100 * (r - f) / r : 0), st, s }'
  [ -n "${KEEP_TMP:-}" ] || rm -rf "$tmp"
done
