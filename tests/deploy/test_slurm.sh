#!/usr/bin/env bash
# deploy/slurm for real: a one-node Slurm cluster started by hand in a temporary directory
# (munged, slurmctld, slurmd, all as root with their files under the directory), a
# coordinator over ipc://, two workers submitted as a job array by
# deploy/slurm/submit-workers.sh, one job. One array task is scancel'ed while it holds a
# lease; the job must still complete, and its film must equal a single-process
# `vcmfarm render` of the same iterations (tests/farm/farm_compare.c).
#
#   test_slurm.sh VCMFARM FARM_COMPARE DEPLOY_DIR
#
# Fails when slurm-wlm or munge is not installed (deploy/install-deps.sh installs them);
# skips (exit 77) when not run as root. Every daemon and process it started is stopped, by PID,
# on every exit path. Nothing is synchronised by fixed sleeps: it polls with deadlines.
set -u
vcmfarm="$1"
compare="$2"
deploy="$3"

skip() { echo "SKIP test_slurm: $*"; exit 77; }
for tool in munged mungekey slurmctld slurmd sbatch squeue scancel sinfo; do
  command -v "$tool" >/dev/null || PATH="$PATH:/usr/sbin:/sbin" command -v "$tool" >/dev/null ||
    { echo "FAIL test_slurm: $tool not found (Debian packages slurm-wlm and munge: bash deploy/install-deps.sh)"; exit 1; }
done
export PATH="$PATH:/usr/sbin:/sbin"
[ "$(id -u)" -eq 0 ] || skip "slurmd must run as root to start jobs; run the test as root"

tmp=$(mktemp -d /tmp/vf-slurm-XXXXXX)
# munged refuses a socket in a directory that not everybody can traverse.
chmod 755 "$tmp"
pids=()    # started by this script directly
daemons=() # munged, slurmctld, slurmd: read from their PID files once they started
# Alive and not a zombie: daemonised processes are children of PID 1, which here need not
# reap them, so kill -0 alone would wait for an exit that already happened.
alive() { [ -e "/proc/$1" ] && ! grep -q '^[0-9]* (.*) Z' "/proc/$1/stat" 2>/dev/null; }
cleanup() {
  trap - EXIT INT TERM
  # Jobs first, while slurmctld and slurmd can still end them cleanly.
  if [ -n "${array:-}" ]; then
    scancel "$array" 2>/dev/null
    local deadline=$((SECONDS + 15))
    while [ -n "$(squeue -h -j "$array" -o %T 2>/dev/null)" ] && [ "$SECONDS" -lt "$deadline" ]; do sleep 0.2; done
  fi
  { for p in "${pids[@]}"; do kill -9 "$p" && wait "$p"; done; } 2>/dev/null
  # Daemons in reverse order of start: slurmd, slurmctld, munged.
  local i
  for ((i = ${#daemons[@]} - 1; i >= 0; i--)); do kill -TERM "${daemons[i]}" 2>/dev/null; done
  local deadline=$((SECONDS + 10))
  for p in "${daemons[@]}"; do
    while alive "$p" && [ "$SECONDS" -lt "$deadline" ]; do sleep 0.1; done
    alive "$p" && kill -9 "$p" 2>/dev/null
  done
  # Anything left that this run started (a slurmstepd, a worker) has its working directory
  # or an open file in $tmp: nothing else does.
  for d in /proc/[0-9]*; do
    p=${d#/proc/}
    [ "$p" != $$ ] || continue
    case "$(readlink "$d/cwd" 2>/dev/null)" in "$tmp"*) kill -9 "$p" 2>/dev/null; continue ;; esac
    for f in "$d"/fd/*; do
      case "$(readlink "$f" 2>/dev/null)" in "$tmp"*) kill -9 "$p" 2>/dev/null; break ;; esac
    done
  done 2>/dev/null
  wait 2>/dev/null
  rm -rf "$tmp"
}
trap cleanup EXIT
trap 'exit 1' INT TERM

fail() {
  echo "FAIL test_slurm: $*"
  for log in "$tmp"/*.log "$tmp"/*.out "$tmp"/munge/*.log; do
    [ -e "$log" ] || continue
    echo "---- $(basename "$log") (last 30 lines)"
    tail -n 30 "$log"
  done
  exit 1
}

wait_until() { # seconds, what, command...
  local seconds="$1" what="$2"
  local deadline=$((SECONDS + seconds))
  shift 2
  until "$@"; do
    [ "$SECONDS" -lt "$deadline" ] || fail "timed out after $seconds s waiting for: $what"
    sleep 0.1
  done
}

source "$(dirname "$0")/../free_port.sh"
ctld_port=$(free_port) || fail "no free TCP port found"
slurmd_port=$(free_port "$ctld_port") || fail "no second free TCP port found"

# --- munge: its own key, socket, pid, log and seed files ------------------------------
mkdir -m 755 "$tmp/munge"
mungekey --create --keyfile="$tmp/munge/munge.key" || fail "mungekey failed"
chmod 600 "$tmp/munge/munge.key"
# The daemons run in the foreground (-F, -D) as children of this script, so that it can
# reap them; they still write their PID files, which say they are up.
munged -F --key-file="$tmp/munge/munge.key" --socket="$tmp/munge/munge.sock" \
  --pid-file="$tmp/munge/munged.pid" --log-file="$tmp/munge/munged.log" \
  --seed-file="$tmp/munge/munged.seed" 2>>"$tmp/munge/munged.log" &
daemons+=($!)
wait_until 10 "munged's PID file" test -s "$tmp/munge/munged.pid"

# --- slurm: a single node, this machine, as it is --------------------------------------
host=$(hostname -s)
cpus=$(nproc)
mkdir -p "$tmp/ctld" "$tmp/spool"
cat >"$tmp/slurm.conf" <<CONF
ClusterName=vcmfarmtest
SlurmctldHost=$host(127.0.0.1)
SlurmctldPort=$ctld_port
SlurmdPort=$slurmd_port
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
CredType=cred/munge
AuthInfo=socket=$tmp/munge/munge.sock
StateSaveLocation=$tmp/ctld
SlurmdSpoolDir=$tmp/spool
SlurmctldPidFile=$tmp/slurmctld.pid
SlurmdPidFile=$tmp/slurmd.pid
SlurmctldLogFile=$tmp/slurmctld.log
SlurmdLogFile=$tmp/slurmd.log
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
SelectType=select/cons_tres
SelectTypeParameters=CR_CPU
SchedulerType=sched/backfill
AccountingStorageType=accounting_storage/none
JobAcctGatherType=jobacct_gather/none
JobCompType=jobcomp/none
MpiDefault=none
MailProg=/bin/true
ReturnToService=2
KillWait=10
NodeName=$host NodeAddr=127.0.0.1 CPUs=$cpus State=UNKNOWN
PartitionName=vcmfarm Nodes=$host Default=YES MaxTime=INFINITE State=UP
CONF
export SLURM_CONF="$tmp/slurm.conf"
# -i: ignore (there is no) saved state.
slurmctld -D -i -f "$SLURM_CONF" 2>>"$tmp/slurmctld.log" &
daemons+=($!)
wait_until 10 "slurmctld's PID file" test -s "$tmp/slurmctld.pid"
slurmd -D -f "$SLURM_CONF" 2>>"$tmp/slurmd.log" &
daemons+=($!)
wait_until 10 "slurmd's PID file" test -s "$tmp/slurmd.pid"
node_idle() { [ "$(sinfo -h -n "$host" -o %T 2>/dev/null)" = idle ]; }
wait_until 30 "node $host to be idle in sinfo" node_idle
echo "slurm up: node $host, $cpus CPUs"

# --- the farm ---------------------------------------------------------------------------
url="ipc://$tmp/coordinator.sock"
key="$tmp/farm.key"
"$vcmfarm" keygen "$key" || fail "keygen failed"
"$vcmfarm" coordinator --listen "$url" --state "$tmp/state" --secret "$key" --lease-seconds 2 \
  --worker-timeout 5 --checkpoint-interval 0.5 >"$tmp/coordinator.log" 2>&1 &
pids+=($!)
client() { "$vcmfarm" "$@" --coordinator "$url" --secret "$key" --timeout 3; }
status_json() { client status "$@" --json 2>/dev/null | tr -d ' \t\n'; }

# Slowed down (--test-iteration-delay) so that the leases outlast the scancel.
array=$(VCMFARM_WORKER_OPTIONS="--test-iteration-delay 150" bash "$deploy/slurm/submit-workers.sh" \
  -n 2 -t 1 -c "$url" -k "$key" -b "$vcmfarm" -- --output="$tmp/worker-%A_%a.out" --chdir="$tmp") ||
  fail "submit-workers.sh failed"
array=${array%%;*}
echo "worker array: job $array"
two_registered() { [ "$(status_json | grep -o "\"name\":\"slurm-${array}_[01]\"" | sort -u | wc -l)" -eq 2 ]; }
wait_until 40 "both array tasks to register with the coordinator" two_registered
squeue -h -j "$array" -o '%i %T %C' | sed 's/^/squeue: /'

iterations=24
job=$(client submit cornell -n "$iterations" -R 64x64 --seed 7 | tail -n 1)
[ -n "$job" ] || fail "submit printed no job id"
victim="slurm-${array}_1"
# The first lease is one iteration (to measure the worker); wait for a longer one, so that
# the cancel lands mid-lease.
victim_leased() {
  local range
  range=$(status_json | sed -n "s/.*\"name\":\"$victim\",\"threads\":1,\"lease\":{\"job\":$job,\"begin\":\([0-9]*\),\"end\":\([0-9]*\)}.*/\1 \2/p")
  [ -n "$range" ] && [ $((${range#* } - ${range% *})) -ge 3 ]
}
wait_until 40 "$victim to hold a lease of 3 or more iterations" victim_leased
scancel "${array}_1" || fail "scancel ${array}_1 failed"
echo "scancel ${array}_1 while it held a lease"
task_gone() { [ -z "$(squeue -h -j "${array}_1" -o %T 2>/dev/null)" ]; }
wait_until 30 "array task ${array}_1 to leave the queue" task_gone
grep -q "worker $victim handed back lease" "$tmp/coordinator.log" ||
  fail "the cancelled task did not hand its lease back"

job_done() { status_json "$job" | grep -q '"state":"done"'; }
wait_until 60 "job $job done with the remaining worker" job_done
"$vcmfarm" fetch "$job" -o "$tmp/farm.exr" --coordinator "$url" --secret "$key" --timeout 3 ||
  fail "fetch failed"
"$vcmfarm" render cornell -n "$iterations" -R 64x64 --seed 7 -j 1 -q -o "$tmp/reference.exr" ||
  fail "reference render failed"
"$compare" "$tmp/farm.exr" "$tmp/reference.exr" "[0,$iterations)" || fail "farm film differs from the reference"
echo "leases per worker: $(grep -o "to worker slurm-[0-9_]*" "$tmp/coordinator.log" | sort | uniq -c | tr '\n' ' ')"
grep -q "to worker slurm-${array}_0" "$tmp/coordinator.log" || fail "task 0 rendered nothing"

scancel "$array"
array_gone() { [ -z "$(squeue -h -j "$array" -o %T 2>/dev/null)" ]; }
wait_until 30 "the worker array to leave the queue" array_gone
array=""
echo "ok   test_slurm"
