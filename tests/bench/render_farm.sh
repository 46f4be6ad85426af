#!/usr/bin/env bash
# The cost of the farm's code path on one machine: the same job rendered by
# `vcmfarm render --direct` and `vcmfarm render` (since render lost its in-process farm,
# both the render loop alone; on older builds `render` ran an in-process coordinator and
# worker), and by a coordinator and one worker as processes over ipc://, submit to
# "done", all with the same threads. Runs alternate, so the machine's drift hits
# every column alike; every farm film is compared with the direct one (tests/farm/farm_compare.c:
# iteration set and pixels). Prints a Markdown table and the medians.
#
#   bash tests/bench/render_farm.sh BUILD_DIR [ITERATIONS] [RUNS] [THREADS]   defaults: 40 6 2
set -u
build="$1"
iterations="${2:-40}"
runs="${3:-6}"
threads="${4:-2}"
vcmfarm="$build/vcmfarm"
compare="$build/tests/farm/farm_compare"
source "$(dirname "${BASH_SOURCE[0]}")/farm_lib.sh"
source "$(dirname "${BASH_SOURCE[0]}")/renderer_lib.sh" # median
farm_setup render-farm
now() { date +%s.%N; }

echo "cornell 512x512, $iterations iterations, $threads render threads, $runs alternating runs"
echo
echo "| run | render --direct | render | coordinator + worker | films |"
echo "|---|---|---|---|---|"
: >"$tmp/direct" && : >"$tmp/render" && : >"$tmp/farm"
verdict() { # FILM: equal/DIFFERENT against the direct film, with the max difference
  "$compare" "$1" "$tmp/direct.exr" "[0,$iterations)" 2>&1 | tail -n 1 |
    sed 's/.*max |difference| \([^,]*\),.*: \([a-z]*\)$/\2 (max difference \1)/'
}
for run in $(seq "$runs"); do
  start=$(now)
  "$vcmfarm" render cornell --direct -n "$iterations" -j "$threads" -q -o "$tmp/direct.exr" || exit 1
  direct=$(echo "$(now) - $start" | bc)
  start=$(now)
  "$vcmfarm" render cornell -n "$iterations" -j "$threads" -q -o "$tmp/render.exr" || exit 1
  render=$(echo "$(now) - $start" | bc)

  rm -rf "$tmp/state"
  "$vcmfarm" coordinator --listen "$url" --state "$tmp/state" --secret "$tmp/key" >"$tmp/coordinator.log" 2>&1 &
  pids+=($!)
  "$vcmfarm" worker --connect "$url" --secret "$tmp/key" --threads "$threads" --name bench >"$tmp/worker.log" 2>&1 &
  pids+=($!)
  deadline=$((SECONDS + 900))
  until [ "$(client status --json 2>/dev/null | grep -c '"threads":')" -eq 1 ]; do
    [ "$SECONDS" -lt "$deadline" ] || { echo "the worker did not register" >&2; exit 1; }
    sleep 0.1
  done
  start=$(now)
  job=$(client submit cornell -n "$iterations" 2>/dev/null | tail -n 1)
  until client status "$job" --json 2>/dev/null | tr -d ' \t\n' | grep -q '"state":"done"'; do
    [ "$SECONDS" -lt "$deadline" ] || { echo "job $job not done in time" >&2; exit 1; }
    sleep 1
  done
  farm=$(echo "$(now) - $start" | bc)
  client fetch "$job" -o "$tmp/farm.exr" >/dev/null 2>&1 || { echo "fetch failed" >&2; exit 1; }
  films="render: $(verdict "$tmp/render.exr"); farm: $(verdict "$tmp/farm.exr")"
  for p in "${pids[@]}"; do kill -TERM "$p" 2>/dev/null; done
  wait 2>/dev/null
  pids=()
  echo "$direct" >>"$tmp/direct"
  echo "$render" >>"$tmp/render"
  echo "$farm" >>"$tmp/farm"
  printf "| %d | %.1f s | %.1f s | %.1f s | %s |\n" "$run" "$direct" "$render" "$farm" "$films"
done
echo
printf "medians: render --direct %.1f s, render %.1f s, coordinator + worker %.1f s\n" "$(median <"$tmp/direct")" \
  "$(median <"$tmp/render")" "$(median <"$tmp/farm")"
