#!/usr/bin/env bash
# Farm jobs with a pilot (docs/PROTOCOL.md, "Pilots"): a coordinator and two one-thread
# workers over ipc://. One case per ctest:
#   exact_pt, exact_vcm      the pilot split across both workers, and the job's film equal
#                            bit for bit (sums, allocation, iterations) to `vcmfarm render`
#                            of the same settings and seed; status shows the pilot's
#                            progress, then the allocation
#   killed_in_pilot          the coordinator killed (SIGKILL) once its pilot film is
#                            checkpointed with part of the pilot: it resumes the pilot from
#                            that film and ends with the same film
#   killed_after_pilot       killed once the job's film holds the allocation and some of
#                            its iterations: no pilot again, the same film
#   exact_auto               `submit -a auto --pilot N`: the client chooses the algorithm by
#                            the candidates' pilots and ships the allocation it chose
#                            (protocol 12): the farm runs no pilot, the job names the
#                            algorithm, and its film is bit for bit `render --allocation-from
#                            FARM_FILM` of that algorithm (auto's choice rests on measured
#                            seconds, so no second choice is compared)
#   given_killed             `submit --allocation-from FILM` of a film of another seed (an
#                            allocation the farm's own pilot would not give): no pilot lease,
#                            status shows the pilot done; the coordinator killed (SIGKILL)
#                            right after the submission resumes the job with that allocation,
#                            and the film is `render --allocation-from FILM`'s bit for bit
#   continued                a film of [0, K) rendered locally with the pilot, continued by
#                            a farm job from iteration K (`submit --start-iteration K`): the
#                            farm reruns the pilot, and the two films merge into the local
#                            render of [0, N) bit for bit
# Every wait is bounded (wait_until); the case's ctest timeout bounds the rest.
set -u
case_name="$1"
vcmfarm="$2"
compare="$3"
fail_label="$case_name"
source "$(dirname "$0")/farm_test_lib.sh"
farm_test_tmp farm-pilot
farm_test_key

registered() { [ "$(grep -c "worker w[12] registered" "$tmp/coordinator.log")" -ge 2 ]; }

iterations=12
pilot=8
algorithm=pt
settings() { echo "-n $iterations -R 64x64 --seed 7 -a $algorithm --pilot $pilot"; }

start_farm() { # worker iteration delay in ms
  start_coordinator --worker-timeout 3
  start_worker w1 --test-iteration-delay "$1" --cache "$tmp/cache-w1"
  start_worker w2 --test-iteration-delay "$1" --cache "$tmp/cache-w2"
  wait_until 30 "both workers registered" registered
}

submit() {
  job=$(client submit cornell $(settings) | tail -n 1)
  [ -n "$job" ] || fail "submit printed no job id"
}

# The farm's film against the local render's (with --allocation-from $allocation_from
# when set), bit for bit; the pilot's leases on both workers and none after the allocation.
allocation_from=
check_film() {
  client fetch "$job" -o "$tmp/farm.exr" || fail "fetch failed"
  "$vcmfarm" render cornell $(settings) ${allocation_from:+--allocation-from "$allocation_from"} -j 1 -q \
    -o "$tmp/reference.exr" || fail "reference render failed"
  "$compare" --exact "$tmp/farm.exr" "$tmp/reference.exr" "[0,$iterations)" ||
    fail "the farm's film differs from the local render's"
  "$vcmfarm" info "$tmp/farm.exr" | grep -q "^allocation " || fail "the farm's film has no allocation: $("$vcmfarm" info "$tmp/farm.exr")"
  status_json | grep -q "\"pilot\":{\"iterations\":$pilot,\"iterations_done\":$pilot,\"allocation\":\"[0-9.]*camerasub-paths" ||
    fail "status does not show the pilot done and its allocation: $(status_json)"
  client status "$job" | grep -q "pilot of $pilot iterations done; allocation: " || fail "status text: $(client status "$job")"
}

pilot_leases_of() { grep -c "job $job pilot iterations \[[0-9]*,[0-9]*) to worker $1" "$tmp/coordinator.log"; }
no_pilot_ran() {
  ! grep -q "job $job pilot iterations\|merged job $job pilot\|job $job: pilot of $pilot iterations done" "$tmp/coordinator.log" ||
    fail "a job submitted with its allocation ran a pilot: $(grep "job $job.*pilot" "$tmp/coordinator.log")"
  grep -q "job $job: submitted with its allocation, no pilot to run" "$tmp/coordinator.log" ||
    fail "the coordinator did not log the submitted allocation"
}

case "$case_name" in
exact_pt | exact_vcm)
  algorithm=${case_name#exact_}
  start_farm 150
  submit
  # The pilot's progress while it runs.
  in_pilot() { status_json | grep -q "\"pilot\":{\"iterations\":$pilot,\"iterations_done\":[0-9]*,\"allocation\":null"; }
  wait_until 30 "status to show the pilot" in_pilot
  client status "$job" | grep -q "pilot: [0-9]*/$pilot iterations" || fail "status text during the pilot: $(client status "$job")"
  wait_until 120 "job $job done" job_done
  [ "$(pilot_leases_of w1)" -ge 1 ] && [ "$(pilot_leases_of w2)" -ge 1 ] ||
    fail "the pilot was not split across both workers: $(grep "pilot iterations" "$tmp/coordinator.log")"
  grep -q "merged job $job pilot" "$tmp/coordinator.log" || fail "no pilot part merged"
  done_line=$(grep -n "job $job: pilot of $pilot iterations done" "$tmp/coordinator.log" | head -n 1 | cut -d: -f1)
  [ -n "$done_line" ] || fail "the coordinator did not log the allocation"
  [ "$(grep -c "job $job: pilot of $pilot iterations done" "$tmp/coordinator.log")" = 1 ] || fail "the allocation was computed more than once"
  # No image lease before the allocation, no pilot lease after it.
  first_image=$(grep -n "job $job iterations \[" "$tmp/coordinator.log" | head -n 1 | cut -d: -f1)
  last_pilot=$(grep -n "job $job pilot iterations \[" "$tmp/coordinator.log" | tail -n 1 | cut -d: -f1)
  [ "$first_image" -gt "$done_line" ] && [ "$last_pilot" -lt "$done_line" ] ||
    fail "leases of the image and the pilot overlap in time: $(grep "lease .*job $job\|pilot of" "$tmp/coordinator.log")"
  check_film
  ;;
exact_auto)
  algorithm=auto
  start_farm 50
  submit
  wait_until 120 "job $job done" job_done
  client fetch "$job" -o "$tmp/farm.exr" || fail "fetch failed"
  algorithm=$("$vcmfarm" info --json "$tmp/farm.exr" | jq -r .algorithm)
  case "$algorithm" in pt | bpt | vcm) ;; *) fail "the job's film names algorithm '$algorithm', not what auto chose" ;; esac
  grep -q "submitted: built-in cornell" "$tmp/coordinator.log" || fail "no job submitted"
  no_pilot_ran
  # The reference takes the farm film's allocation and algorithm: what auto would choose
  # again on this machine does not enter.
  cp "$tmp/farm.exr" "$tmp/chosen.exr"
  allocation_from="$tmp/chosen.exr"
  check_film
  ;;
given_killed)
  algorithm=vcm
  start_farm 250
  # An allocation of another seed's pilot: the farm's pilot (seed 7) would decide others.
  "$vcmfarm" render cornell -n 2 -R 64x64 --seed 3 -a vcm --pilot $pilot -j 1 -q -o "$tmp/given.exr" ||
    fail "the local render giving the allocation failed"
  allocation_from="$tmp/given.exr"
  job=$(client submit cornell $(settings) --allocation-from "$allocation_from" | tail -n 1)
  [ -n "$job" ] || fail "submit printed no job id"
  kill -9 "$coordinator"
  wait_until 10 "the coordinator to die" exited "$coordinator"
  [ -s "$state/job-$job.exr" ] || fail "the job's film with its allocation was not written before the answer"
  "$vcmfarm" info "$state/job-$job.exr" | grep "^allocation " >"$tmp/state-allocation.txt"
  "$vcmfarm" info "$tmp/given.exr" | grep "^allocation " | cmp -s - "$tmp/state-allocation.txt" ||
    fail "the film written at submission lacks the allocation: $("$vcmfarm" info "$state/job-$job.exr")"
  start_coordinator --worker-timeout 3
  wait_until 120 "job $job done after the restart" job_done
  grep -q "resumed job $job " "$tmp/coordinator.log" || fail "the restarted coordinator did not resume job $job"
  no_pilot_ran
  check_film
  # check_film compared allocations too: the farm's film has FILM's, not its own pilot's.
  "$vcmfarm" render cornell $(settings) -n 1 -j 1 -q -o "$tmp/own-pilot.exr" || fail "the render with a pilot failed"
  [ "$("$vcmfarm" info "$tmp/own-pilot.exr" | grep "^allocation ")" != "$(cat "$tmp/state-allocation.txt")" ] ||
    fail "seeds 3 and 7 give the same allocation: the case cannot tell them apart"
  ;;
killed_in_pilot)
  pilot=16
  start_farm 250
  submit
  pilot_checkpointed() {
    [ -s "$state/job-$job.pilot.exr" ] && [ "$(grep -c "merged job $job pilot" "$tmp/coordinator.log")" -ge 1 ]
  }
  wait_until 60 "a pilot part merged and the pilot film checkpointed" pilot_checkpointed
  kill -9 "$coordinator"
  wait_until 10 "the coordinator to die" exited "$coordinator"
  grep -q "job $job: pilot of $pilot iterations done" "$tmp/coordinator.log" && fail "the pilot ended before the kill: make it longer"
  start_coordinator --worker-timeout 3
  wait_until 120 "job $job done after the restart" job_done
  resumed=$(sed -n "s/.*job $job: pilot resumed with \([0-9]*\)\/$pilot iterations.*/\1/p" "$tmp/coordinator.log")
  [ -n "$resumed" ] && [ "$resumed" -gt 0 ] || fail "the restarted coordinator did not resume the pilot film"
  echo "resumed the pilot with $resumed of $pilot iterations"
  check_film
  ;;
killed_after_pilot)
  start_farm 150
  submit
  image_checkpointed() {
    [ "$(job_number iterations_done)" -ge 2 ] 2>/dev/null && [ -s "$state/job-$job.exr" ] &&
      "$vcmfarm" info "$state/job-$job.exr" 2>/dev/null | grep -q "^allocation " &&
      "$vcmfarm" info "$state/job-$job.exr" 2>/dev/null | grep -q "^iterations *\[0,"
  }
  wait_until 90 "the job's film checkpointed with its allocation and iterations" image_checkpointed
  kill -9 "$coordinator"
  wait_until 10 "the coordinator to die" exited "$coordinator"
  restart_line=$(($(wc -l <"$tmp/coordinator.log") + 1))
  start_coordinator --worker-timeout 3
  wait_until 120 "job $job done after the restart" job_done
  tail -n +"$restart_line" "$tmp/coordinator.log" | grep -q "pilot iterations\|pilot resumed\|pilot of $pilot iterations done" &&
    fail "the pilot ran again after the restart: $(tail -n +"$restart_line" "$tmp/coordinator.log" | grep pilot)"
  [ -e "$state/job-$job.pilot.exr" ] && fail "the pilot film outlived the allocation's checkpoint and a restart"
  check_film
  ;;
continued)
  first=5
  start_farm 50
  "$vcmfarm" render cornell $(settings | sed "s/-n $iterations/-n $first/") -j 1 -q -o "$tmp/first.exr" ||
    fail "the local render of [0,$first) failed"
  job=$(client submit cornell $(settings | sed "s/-n $iterations/-n $((iterations - first))/") --start-iteration "$first" |
    tail -n 1)
  [ -n "$job" ] || fail "submit printed no job id"
  wait_until 120 "job $job done" job_done
  [ "$(pilot_leases_of w1)" -ge 1 ] || [ "$(pilot_leases_of w2)" -ge 1 ] ||
    fail "the continuing job ran no pilot: $(grep "job $job" "$tmp/coordinator.log")"
  client fetch "$job" -o "$tmp/farm.exr" || fail "fetch failed"
  "$vcmfarm" info "$tmp/farm.exr" | grep -q "^iterations *\[$first,$iterations)" ||
    fail "the farm's film does not hold [$first,$iterations): $("$vcmfarm" info "$tmp/farm.exr")"
  # The farm's allocation is the local pilot's: otherwise merge refuses the pair.
  "$vcmfarm" merge -q -o "$tmp/merged.exr" "$tmp/first.exr" "$tmp/farm.exr" ||
    fail "the local film and the farm's continuation do not merge"
  "$vcmfarm" render cornell $(settings) -j 1 -q -o "$tmp/reference.exr" || fail "reference render failed"
  "$compare" --exact "$tmp/merged.exr" "$tmp/reference.exr" "[0,$iterations)" ||
    fail "the merged film differs from the local render of [0,$iterations)"
  ;;
*)
  fail "unknown case $case_name"
  ;;
esac
echo "PASS $case_name"
