#!/usr/bin/env bash
# The dashboard's cost to the coordinator (docs/BENCHMARKS.md, "Dashboard"): CPU seconds
# of the coordinator process (utime + stime of /proc/PID/stat) over SECONDS while a job
# renders on one worker, first with nobody watching, then with one headless chromium
# keeping the page open (tests/coordinator/dashboard/browser/watch.js: status and events every 2 s, the job,
# its preview every 3 s).
#
#   dashboard_cpu.sh VCMFARM WORK_DIR [SECONDS]   (WORK_DIR: where test_dashboard installed
#                                                  playwright-core, build/tests/coordinator/dashboard/browser)
set -eu
vcmfarm="$1"
work="$2"
seconds="${3:-60}"
src=$(cd "$(dirname "$0")/../coordinator/dashboard/browser" && pwd)
cp "$src/watch.js" "$work/"
tmp=$(mktemp -d /tmp/vf-dash-cpu-XXXXXX)
pids=()
trap 'for p in "${pids[@]}"; do kill -9 "$p" 2>/dev/null; done; wait 2>/dev/null; rm -rf "$tmp"' EXIT
url="ipc://$tmp/c.sock"
"$vcmfarm" keygen "$tmp/k" >/dev/null
"$vcmfarm" coordinator --listen "$url" --state "$tmp/state" --secret "$tmp/k" --http 127.0.0.1:0 >"$tmp/c.log" 2>&1 &
coordinator=$!
pids+=($coordinator)
sleep 1
base=$(grep -o 'dashboard on http://127\.0\.0\.1:[0-9]*' "$tmp/c.log" | sed 's/dashboard on //')
"$vcmfarm" worker --connect "$url" --secret "$tmp/k" --threads 1 --name w1 --test-iteration-delay 100 >"$tmp/w.log" 2>&1 &
pids+=($!)
"$vcmfarm" submit cornell -R 256x256 --iterations 1000000 --coordinator "$url" --secret "$tmp/k" >/dev/null
sleep 5
ticks=$(getconf CLK_TCK)
cpu() { awk '{print $14 + $15}' "/proc/$coordinator/stat"; }
measure() { # label, then the command that runs meanwhile
  local label="$1" a b
  shift
  a=$(cpu)
  "$@"
  b=$(cpu)
  awk -v l="$label" -v a="$a" -v b="$b" -v t="$ticks" -v s="$seconds" \
    'BEGIN { printf "%-22s %6.2f CPU s in %d s: %5.2f%% of a core\n", l, (b - a) / t, s, 100 * (b - a) / t / s }'
}
measure "nobody watching" sleep "$seconds"
measure "one browser open" node "$work/watch.js" "$base" "$(command -v chromium)" "$seconds"
