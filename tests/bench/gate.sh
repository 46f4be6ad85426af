#!/usr/bin/env bash
# What the coordinator's TCP gate costs (docs/BENCHMARKS.md, "The TCP gate"): two builds
# side by side over tcp:// on loopback, one coordinator and one job each, runs alternated.
# Each job is a 3840x2160 film (pt, two bounces, one iteration, rendered by one worker);
# then, RUNS times per build: the film fetched (replies of up to 4 MiB, about 22 of them),
# and 100 `vcmfarm status` calls in a row (small requests; each a process, so the
# difference between builds is what the transport adds).
#
#   bash tests/bench/gate.sh BUILD_A BUILD_B [RUNS]
set -u
builds=("$1" "$2")
runs=${3:-5}
tmp=$(mktemp -d /tmp/vf-bench-gate-XXXXXX)
export TMPDIR="$tmp" # the coordinators' private sockets, removed with it
pids=()
trap 'for p in "${pids[@]}"; do kill -9 "$p" 2>/dev/null; done; wait 2>/dev/null; rm -rf "$tmp"' EXIT
"${builds[0]}/vcmfarm" keygen "$tmp/key" >/dev/null || exit 1
free_port() { python3 -c 'import socket; s=socket.socket(); s.bind(("127.0.0.1",0)); print(s.getsockname()[1])'; }

urls=()
for i in 0 1; do
  v="${builds[$i]}/vcmfarm"
  port=$(free_port)
  urls[$i]="tcp://127.0.0.1:$port"
  "$v" coordinator --listen "${urls[$i]}" --state "$tmp/state$i" --secret "$tmp/key" >"$tmp/coordinator$i.log" 2>&1 &
  pids+=($!)
  sleep 0.5
  "$v" worker --connect "${urls[$i]}" --secret "$tmp/key" --threads 2 --name "w$i" >"$tmp/worker$i.log" 2>&1 &
  pids+=($!)
  "$v" submit cornell -R 3840x2160 -n 1 -l 2 -a pt --seed 7 --coordinator "${urls[$i]}" --secret "$tmp/key" \
    --wait -o "$tmp/first$i.exr" >/dev/null 2>&1 || { echo "build $i: the job failed" >&2; exit 1; }
done
echo "film: $(stat -c %s "$tmp/first0.exr") bytes"

for r in $(seq "$runs"); do
  for i in 0 1; do
    v="${builds[$i]}/vcmfarm"
    t0=$(date +%s.%N)
    "$v" fetch 1 -o "$tmp/f$i.exr" --coordinator "${urls[$i]}" --secret "$tmp/key" --timeout 30 || exit 1
    t1=$(date +%s.%N)
    for _ in $(seq 100); do
      "$v" status --coordinator "${urls[$i]}" --secret "$tmp/key" >/dev/null || exit 1
    done
    t2=$(date +%s.%N)
    awk -v b="${builds[$i]}" -v r="$r" -v a="$t0" -v m="$t1" -v z="$t2" \
      'BEGIN { printf "run %d %-28s fetch %.3f s   100 x status %.3f s\n", r, b, m - a, z - m }'
  done
done
