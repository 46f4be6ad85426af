#!/usr/bin/env bash
# deploy/systemd: the units pass `systemd-analyze verify` with no warning at all (verify
# only warns about a bad value, so any output fails), pointing at the built binary; then
# their ExecStart= lines run for real, with systemd's specifiers and environment filled in
# as systemd would (%d: a credentials directory holding the key, mode 0400; %S: a state
# root; %H, %i), so a misspelt option cannot hide in a unit: the coordinator and a worker
# start from the units' own command lines and the worker renders a job.
#
#   test_systemd.sh VCMFARM DEPLOY_DIR
set -u
vcmfarm="$1"
units="$2/systemd"
command -v systemd-analyze >/dev/null ||
  { echo "FAIL test_systemd: systemd-analyze not found (Debian package systemd: bash deploy/install-deps.sh)"; exit 1; }
tmp=$(mktemp -d /tmp/vf-systemd-XXXXXX)
pids=()
cleanup() {
  { for p in "${pids[@]}"; do kill -9 "$p" && wait "$p"; done; } 2>/dev/null
  rm -rf "$tmp"
}
trap cleanup EXIT
fail() {
  echo "FAIL test_systemd: $*"
  for log in "$tmp"/*.log; do [ -e "$log" ] && { echo "---- $(basename "$log")"; tail -n 20 "$log"; }; done
  exit 1
}

# --- systemd-analyze verify -------------------------------------------------------------
mkdir "$tmp/units"
for unit in vcmfarm-coordinator.service vcmfarm-worker@.service; do
  [ -f "$units/$unit" ] || fail "missing $units/$unit"
  sed "s#/usr/local/bin/vcmfarm#$vcmfarm#g" "$units/$unit" >"$tmp/units/$unit"
done
for unit in vcmfarm-coordinator.service vcmfarm-worker@1.service; do
  out=$(cd "$tmp/units" && systemd-analyze verify --man=no "./$unit" 2>&1)
  status=$?
  [ "$status" -eq 0 ] && [ -z "$out" ] || fail "systemd-analyze verify $unit (status $status): $out"
  echo "verified $unit"
done

# --- the ExecStart= lines, run as systemd would run them ---------------------------------
exec_start() { # unit: its ExecStart= with specifiers replaced
  sed -n 's/^ExecStart=//p' "$tmp/units/$1" |
    sed -e "s#%d#$tmp/credentials#g" -e "s#%S#$tmp/var-lib#g" -e "s#%H#$(hostname)#g" -e "s#%i#1#g"
}
setting() { # unit, variable: its Environment= default
  sed -n "s/^Environment=$2=//p" "$tmp/units/$1"
}
mkdir -m 700 "$tmp/credentials" "$tmp/var-lib"
"$vcmfarm" keygen "$tmp/farm.key" >/dev/null || fail "keygen failed"
install -m 400 "$tmp/farm.key" "$tmp/credentials/farm.key"
[ "$(setting vcmfarm-coordinator.service VCMFARM_LISTEN)" = "tcp://0.0.0.0:5555" ] ||
  fail "the coordinator's default VCMFARM_LISTEN is not tcp://0.0.0.0:5555"
# Port 5555 may be taken on a shared machine: the same line, on a free loopback port.
source "$(dirname "$0")/../free_port.sh"
port=$(free_port) || fail "no free TCP port found"
export VCMFARM_LISTEN="tcp://127.0.0.1:$port" VCMFARM_CONNECT="tcp://127.0.0.1:$port"
export TMPDIR="$tmp" # PrivateTmp=yes: the socket behind the coordinator's TCP gate goes there
export VCMFARM_COORDINATOR_OPTIONS="--checkpoint-interval 0.5" VCMFARM_WORKER_OPTIONS="--threads 1"
# systemd splits ${VAR} as one word and $VAR into words; eval with the unit's quoting does the same here.
coordinator_line=$(exec_start vcmfarm-coordinator.service | sed -e 's/\${\([A-Z_]*\)}/"${\1}"/g')
worker_line=$(exec_start vcmfarm-worker@.service | sed -e 's/\${\([A-Z_]*\)}/"${\1}"/g')
echo "coordinator: $coordinator_line"
echo "worker:      $worker_line"
eval "exec $coordinator_line" >"$tmp/coordinator.log" 2>&1 &
pids+=($!)
eval "exec $worker_line" >"$tmp/worker.log" 2>&1 &
pids+=($!)
client() { "$vcmfarm" "$@" --coordinator "$VCMFARM_CONNECT" --secret "$tmp/farm.key" --timeout 3; }
deadline=$((SECONDS + 60))
job=$(client submit cornell -n 2 -R 32x32 --seed 3 2>>"$tmp/submit.log" | tail -n 1)
[ -n "$job" ] || fail "submit failed"
until client status "$job" --json 2>/dev/null | tr -d ' \t\n' | grep -q '"state":"done"'; do
  [ "$SECONDS" -lt "$deadline" ] || fail "job $job not done within 60 s"
  sleep 0.1
done
grep -q "worker $(hostname)-1 registered" "$tmp/coordinator.log" || fail "the worker's name is not HOST-INSTANCE"
[ -s "$tmp/var-lib/vcmfarm/state.json" ] || fail "no state in %S/vcmfarm"
echo "ok   test_systemd: job $job rendered by worker $(hostname)-1 from the units' command lines"
