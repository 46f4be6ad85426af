#!/bin/bash
# The long run of the fault soak (tests/farm/test_farm_faults.sh soak_stalls, whose CI run
# is bounded to SOAK_SECONDS=35): random SIGKILLs and SIGSTOP/SIGCONTs of workers and the
# coordinator, a 16 s coordinator pause, gate congestion by a peer without the key, while
# a job of N iterations and a job of a time limit render over tcp://; it passes when no job
# failed and both films equal --direct of their iterations.
#
#   bash tests/bench/farm_soak.sh BUILD [RUNS [SECONDS]]
#
# RUNS soaks (default 3) of SECONDS of faults each (default 600), seeds 1..RUNS; the
# iterations and time limit grow with SECONDS so that both jobs outlast the faults.
set -u
build=${1:?usage: farm_soak.sh BUILD [RUNS [SECONDS]]}
runs=${2:-3}
seconds=${3:-600}
here=$(cd "$(dirname "$0")/.." && pwd)
passed=0
for seed in $(seq "$runs"); do
  out=$(SOAK_SECONDS=$seconds SOAK_SEED=$seed SOAK_ITERATIONS=$((seconds * 14)) SOAK_TIME_LIMIT=$((seconds * 3 / 4)) SOAK_END_WAIT=$seconds \
    bash "$here/farm/test_farm_faults.sh" soak_stalls "$build/vcmfarm" "$build/tests/farm/farm_compare" \
    "$build/tests/farm/farm_peer" 2>&1)
  status=$?
  echo "$out" | grep -E "^soak_stalls: [0-9]+ faults"
  echo "$out" | grep -E "^ok|^FAIL|^exact:|^not bit|^farm \[" | cut -c1-400
  [ "$status" = 0 ] && passed=$((passed + 1))
done
echo "farm_soak: $passed of $runs soaks passed ($seconds s of faults each)"
[ "$passed" = "$runs" ]
