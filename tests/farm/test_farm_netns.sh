#!/usr/bin/env bash
# The farm across a network that fails, end to end: the coordinator and each worker in a
# network namespace of their own that this test creates (a bridge in the coordinator's
# namespace, one veth pair per worker, addresses 10.77.0.0/24 that exist only inside them;
# nothing reaches any other network), the real binary's processes over tcp://:
#
#   partition_worker   one worker of three cut off (its link down) for longer than the
#                      coordinator's worker timeout, then back: its lease goes to the others
#                      and it rejoins;
#   isolate_coordinator the coordinator cut off from every worker at once (the bridge down)
#                      for longer than the worker timeout, then back;
#   flapping           one worker's link taken down and up every 0.3-1.5 s for 15 s;
#   netem              latency, loss and reordering on every worker's link (tc netem).
#
# Each case ends when the job is done: no job failed, and the film equals `render --direct`
# of the same iterations bit for bit (tests/farm/farm_compare.c --exact).
# Without root, or where the kernel cannot make namespaces, veth pairs or bridges, every
# case says so and exits 77 (skipped); netem alone needs the sch_netem module, and skips
# when the kernel has none.
#
#   test_farm_netns.sh CASE VCMFARM FARM_COMPARE
#
# No fixed sleeps synchronise anything: the script polls `vcmfarm status` with a deadline
# (the faults themselves are timed); every process it starts is killed and every
# namespace deleted on exit. KEEP_TMP=1 keeps the logs.
set -u
case_name="$1"
vcmfarm="$2"
compare="$3"
fail_label="netns $case_name"
source "$(dirname "$0")/farm_test_lib.sh"

ns="vf$$"                 # this run's namespace names: ${ns}c, ${ns}w1, ...
coordinator_ns="${ns}c"
namespaces=()
farm_test_on_exit() {
  local n
  for n in "${namespaces[@]}"; do ip netns del "$n" 2>/dev/null; done
}
farm_test_tmp netns
farm_test_key

skip() {
  echo "SKIP $fail_label: $*"
  exit 77
}
[ "$(id -u)" = 0 ] || skip "needs root to create network namespaces"
command -v ip >/dev/null || skip "no ip command (iproute2)"

# The coordinator's namespace with its bridge at 10.77.0.1, then one namespace per worker
# joined to the bridge by a veth pair, at 10.77.0.(k+1).
make_network() { # number of workers
  ip netns add "$coordinator_ns" 2>/dev/null || skip "the kernel cannot create a network namespace here"
  namespaces+=("$coordinator_ns")
  ip netns exec "$coordinator_ns" true 2>/dev/null || skip "cannot run a process in a network namespace here (ip netns exec)"
  ip -n "$coordinator_ns" link set lo up
  ip -n "$coordinator_ns" link add br0 type bridge 2>/dev/null || skip "the kernel cannot create a bridge here"
  ip -n "$coordinator_ns" addr add 10.77.0.1/24 dev br0
  ip -n "$coordinator_ns" link set br0 up
  local k
  for k in $(seq 1 "$1"); do
    ip netns add "${ns}w$k" || fail "namespace ${ns}w$k"
    namespaces+=("${ns}w$k")
    ip -n "${ns}w$k" link set lo up
    ip link add "${ns}a$k" netns "$coordinator_ns" type veth peer name eth0 netns "${ns}w$k" 2>/dev/null ||
      skip "the kernel cannot create a veth pair here"
    ip -n "$coordinator_ns" link set "${ns}a$k" master br0
    ip -n "$coordinator_ns" link set "${ns}a$k" up
    ip -n "${ns}w$k" addr add "10.77.0.$((k + 1))/24" dev eth0
    ip -n "${ns}w$k" link set eth0 up
  done
}

port=$((20000 + $$ % 20000))
url="tcp://10.77.0.1:$port"
client() { # command, arguments...
  ip netns exec "$coordinator_ns" "$vcmfarm" "$@" --coordinator "$url" --secret "$key" --timeout 3
}
start_net_coordinator() {
  ip netns exec "$coordinator_ns" "$vcmfarm" coordinator --listen "$url" --state "$state" --secret "$key" \
    --lease-seconds 1 --checkpoint-interval 0.5 --worker-timeout 3 --forgive 2 >>"$tmp/coordinator.log" 2>&1 &
  coordinator=$!
  pids+=("$coordinator")
}
start_net_worker() { # k
  ip netns exec "${ns}w$1" "$vcmfarm" worker --connect "$url" --secret "$key" --threads 1 --name "w$1" \
    --test-iteration-delay 30 >>"$tmp/w$1.log" 2>&1 &
  pids+=("$!")
}
link() { # k up|down: worker k's end of its veth pair on the bridge
  ip -n "$coordinator_ns" link set "${ns}a$1" "$2"
}

is_state() { [ "$(state_of "$1")" = "$2" ]; }
done_count() { job_field "$1" iterations_done; }
progressed() { local d; d=$(done_count "$job"); [ -n "$d" ] && [ "$d" -gt "$1" ]; }
answers() { [ -n "$(state_of "$job")" ]; }

iterations=${NETNS_ITERATIONS:-600}
workers=3
make_network "$workers"
if [ "$case_name" = netem ]; then
  ip netns exec "${ns}w1" tc qdisc add dev eth0 root netem delay 1ms 2>/dev/null ||
    skip "tc netem is not available in this kernel (module sch_netem): latency, loss and reordering not tested"
  ip netns exec "${ns}w1" tc qdisc del dev eth0 root
fi
start_net_coordinator
wait_until 20 "the coordinator to answer" eval 'client status --json >/dev/null 2>&1'
job=$(client submit cornell -n "$iterations" -R 32x32 --seed 11 | tail -n 1)
[ -n "$job" ] || fail "submit printed no job id"
for k in $(seq 1 "$workers"); do start_net_worker "$k"; done
wait_until 60 "job $job to start" progressed 0

case "$case_name" in
partition_worker)
  base=$(done_count "$job")
  link 1 down
  echo "w1 cut off" >>"$tmp/faults.log"
  sleep 6 # twice the worker timeout: w1 is lost, its lease goes to the others
  wait_until 60 "the others to go on without w1" progressed "$base"
  link 1 up
  echo "w1 back" >>"$tmp/faults.log"
  ;;
isolate_coordinator)
  base=$(done_count "$job")
  ip -n "$coordinator_ns" link set br0 down
  echo "coordinator cut off" >>"$tmp/faults.log"
  sleep 6
  ip -n "$coordinator_ns" link set br0 up
  echo "coordinator back" >>"$tmp/faults.log"
  wait_until 60 "the job to progress after the coordinator came back" progressed "$base"
  ;;
flapping)
  RANDOM=${NETNS_SEED:-$$}
  end=$((SECONDS + 15))
  flaps=0
  while [ "$SECONDS" -lt "$end" ] && ! is_state "$job" done; do
    link 2 down
    sleep "0.$((RANDOM % 7 + 3))"
    link 2 up
    sleep "$((RANDOM % 2)).$((RANDOM % 10))"
    flaps=$((flaps + 1))
  done
  echo "w2's link went down $flaps times" >>"$tmp/faults.log"
  ;;
netem)
  for k in $(seq 1 "$workers"); do
    ip netns exec "${ns}w$k" tc qdisc add dev eth0 root netem delay 40ms 20ms loss 3% reorder 10% 50% ||
      fail "netem on w$k"
  done
  ip netns exec "$coordinator_ns" tc qdisc add dev br0 root netem delay 20ms 10ms loss 2% || fail "netem on the bridge"
  ;;
*)
  echo "unknown case $case_name"
  exit 2
  ;;
esac

wait_until 240 "job $job done" eval 'is_state '"$job"' done || is_state '"$job"' failed'
is_state "$job" done || fail "job $job is $(state_of "$job"): $(job_field "$job" message)"
client fetch "$job" -o "$tmp/farm.exr" || fail "fetch failed"
"$vcmfarm" render cornell --direct -n "$iterations" -R 32x32 --seed 11 -j 1 -q -o "$tmp/reference.exr" ||
  fail "reference render failed"
"$compare" --exact "$tmp/farm.exr" "$tmp/reference.exr" "[0,$iterations)" ||
  fail "the film differs from --direct"
echo "ok   $case_name: $(cat "$tmp/faults.log" 2>/dev/null | tr '\n' ';') job done, the film equals --direct bit for bit"
