# Shared set-up of the farm's end-to-end test scripts (test_farm.sh, test_farm_faults.sh,
# test_dashboard.sh, test_dashboard_http.sh, test_render_farm.sh), sourced after `vcmfarm`
# is set:
#
#   farm_test_tmp NAME      a private directory $tmp (/tmp/vf-NAME-XXXXXX); every process
#                           appended to `pids` is killed on exit, then farm_test_on_exit
#                           (when the script defines it) runs and $tmp is removed
#                           (KEEP_TMP=1 keeps it)
#   farm_test_key           a farm key $key in it and an ipc:// $url beside it
#   fail MESSAGE            "FAIL $fail_label: MESSAGE" and the end of every log in $tmp
#   start_coordinator ARGS  a coordinator on $url with state in $state ($tmp/state), short
#                           leases and checkpoints; its pid in $coordinator; returns once
#                           an ipc:// one listens (or has ended)
#   start_worker NAME ARGS  a one-thread worker named NAME logging to $tmp/NAME.log; its pid
#                           in $last_worker
#   wait_until S WHAT CMD   runs CMD every 50 ms until it succeeds; after S seconds fails
#                           saying what it waited for
#   exited PID              whether that process has ended
#   dashboard_address       waits for the coordinator's log to say where its dashboard
#                           listens and sets $base to that http://127.0.0.1:PORT
#   status_of JOB, job_field JOB FIELD, state_of JOB
#                           the job's `status --json`, one of its fields, its state ("" when
#                           no coordinator answers), through the script's own `client`

# The children of a process (a supervisor's worker), from /proc: procps may be absent.
children_of() { # pid
  local parent="$1" stat fields
  for stat in /proc/[0-9]*/stat; do
    read -r fields <"$stat" 2>/dev/null || continue
    fields=${fields##*) } # the fields after the command name, which may hold spaces
    set -- $fields        # state, parent, ...
    [ "${2:-}" = "$parent" ] || continue
    stat=${stat#/proc/}
    echo "${stat%/stat}"
  done
}

farm_test_cleanup() {
  local p c
  # A supervisor's worker first: killing the supervisor alone would leave it running.
  for p in "${pids[@]}"; do
    for c in $(children_of "$p"); do kill -9 "$c" 2>/dev/null; done
    kill -9 "$p" 2>/dev/null
  done
  wait 2>/dev/null
  declare -F farm_test_on_exit >/dev/null && farm_test_on_exit
  [ -n "${KEEP_TMP:-}" ] || rm -rf "$tmp"
}

farm_test_tmp() { # name
  tmp=$(mktemp -d "/tmp/vf-$1-XXXXXX")
  pids=()
  state="$tmp/state"
  trap farm_test_cleanup EXIT
}

fail() {
  echo "FAIL ${fail_label:-test}: $*"
  for log in "$tmp"/*.log; do
    [ -e "$log" ] || continue
    echo "---- $(basename "$log") (last 40 lines)"
    tail -n 40 "$log"
  done
  exit 1
}

farm_test_key() {
  url="ipc://$tmp/coordinator.sock"
  key="$tmp/farm.key"
  "$vcmfarm" keygen "$key" >/dev/null || fail "keygen"
}

start_coordinator() { # extra options...
  "$vcmfarm" coordinator --listen "$url" --state "$state" --secret "$key" --lease-seconds 0.3 \
    --checkpoint-interval 0.3 "$@" >>"$tmp/coordinator.log" 2>&1 &
  coordinator=$!
  pids+=("$coordinator")
  # A client's wait for a connection gives up after 0.8 s with "no coordinator answered":
  # give an ipc:// coordinator up to 10 s to listen (a socket left by a killed one counts),
  # unless it ends first.
  if [[ "$url" == ipc://* ]]; then
    for _ in $(seq 200); do
      { [ -S "${url#ipc://}" ] || ! kill -0 "$coordinator" 2>/dev/null; } && break
      sleep 0.05
    done
  fi
}

start_worker() { # name, extra options...
  local name="$1"
  shift
  "$vcmfarm" worker --connect "$url" --secret "$key" --threads 1 --name "$name" "$@" >>"$tmp/$name.log" 2>&1 &
  last_worker=$!
  pids+=("$last_worker")
}

dashboard_address() {
  base=""
  for _ in $(seq 100); do
    base=$(grep -o 'dashboard on http://127\.0\.0\.1:[0-9]*' "$tmp/coordinator.log" | sed 's/dashboard on //')
    [ -n "$base" ] && return 0
    sleep 0.1
  done
  fail "the coordinator did not say where its dashboard is"
}

wait_until() { # seconds, what, command...
  local limit="$1" deadline=$((SECONDS + $1)) what="$2"
  shift 2
  until "$@"; do
    [ "$SECONDS" -lt "$deadline" ] || fail "timed out after $limit s waiting for: $what"
    sleep 0.05
  done
}

exited() { ! kill -0 "$1" 2>/dev/null; }

# The farm's command line for the test's coordinator ($url, $key); a script whose
# coordinator is reached another way (test_farm_netns.sh) defines its own after sourcing.
client() { # command, arguments...
  "$vcmfarm" "$@" --coordinator "$url" --secret "$key" --timeout 3
}
# The compact JSON of `status JOB --json` for the script's $job, for matching with grep.
status_json() { client status "$job" --json 2>/dev/null | tr -d ' \t\n'; }
job_number() { status_json | sed -n "s/.*\"$1\":\([0-9]*\).*/\1/p"; }
job_done() { status_json | grep -q '"state":"done"'; }

status_of() { client status "$1" --json 2>/dev/null; } # through `client`
# A field of the job in `status JOB --json`; "" when the coordinator does not answer.
job_field() { # job, field
  status_of "$1" | python3 -c '
import json, sys
try:
    jobs = json.load(sys.stdin)["jobs"]
    print(next(j for j in jobs if j["id"] == int(sys.argv[1]))[sys.argv[2]])
except Exception:
    pass' "$1" "$2"
}
state_of() { job_field "$1" state; }
