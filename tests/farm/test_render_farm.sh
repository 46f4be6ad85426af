#!/usr/bin/env bash
# `vcmfarm render` and a farm give the same film, the product's promise: a coordinator and
# one worker as processes over ipc://, each job submitted and fetched (`submit --wait`),
# its film compared bit for bit with `vcmfarm render` of the same global iterations
# (tests/farm/farm_compare.c --exact: the film's sums are exact integers, so the order in
# which the farm adds its parts changes nothing). And what `render` promises on its own,
# its films compared bit for bit with a render of the same iterations (farm_compare
# --exact: scene hash, settings and every sum): --direct, a target tested after every
# iteration, a time limit, SIGINT, a SIGKILL that leaves the last checkpoint, which
# `continue` resumes, and no file beside its film.
#
#   test_render_farm.sh VCMFARM FARM_COMPARE SOURCE_DIR
set -u
vcmfarm="$1"
compare="$2"
source_dir="$3"
source "$(dirname "$0")/farm_test_lib.sh"
farm_test_tmp render-farm
farm_test_key
mkdir "$tmp/films" "$tmp/tmpdir"
# render and continue, with a TMPDIR of their own: they make no temporary directory or file
# there (checked at the end).
local_render() { TMPDIR="$tmp/tmpdir" "$vcmfarm" "$@"; }
failures=0
check() { # NAME STATUS
  if [ "$2" -eq 0 ]; then echo "ok   $1"; else echo "FAIL $1"; failures=$((failures + 1)); fi
}

# The iteration set of a film, as `vcmfarm info` prints it.
iterations_of() { "$vcmfarm" info "$1" | awk '$1 == "iterations" {print $2}'; }
# Its end: the N of [K,N).
end_of() { iterations_of "$1" | sed -n 's/^\[\([0-9]*\),\([0-9]*\))$/\2/p'; }
estimate_of() { "$vcmfarm" info "$1" | awk '$1 == "estimated_rmse" {print $2}'; }

start_coordinator
start_worker w1
client=(--coordinator "$url" --secret "$key" --timeout 10)

# farm NAME SET FILM SUBMIT_ARGS...: the job of SUBMIT_ARGS through the farm, its film
# compared with FILM (a render's).
farm() {
  local name="$1" set="$2" film="$3"
  shift 3
  timeout 240 "$vcmfarm" submit "$@" --wait -o "$tmp/films/farm.exr" "${client[@]}" >"$tmp/submit.log" 2>&1 &&
    "$compare" --exact "$tmp/films/farm.exr" "$film" "$set"
  check "$name" $?
}
# same [--close] NAME SET FILM RENDER_ARGS...: FILM is, bit for bit, the render of
# RENDER_ARGS; with --close, to 1e-5 of the image mean only.
same() {
  local exact=--exact
  [ "$1" = --close ] && exact="" && shift
  local name="$1" set="$2" film="$3"
  shift 3
  local_render render "$@" -q -o "$tmp/films/same.exr" && "$compare" $exact "$film" "$tmp/films/same.exr" "$set"
  check "$name" $?
}

common=(-R 64x48 --seed 3)

# 1. Iterations [0, 6), rendered with two threads; the farm's worker has one.
local_render render cornell "${common[@]}" -n 6 -j 2 -q -o "$tmp/films/a.exr"
check "render exits 0" $?
farm "the farm's film is render's" "[0,6)" "$tmp/films/a.exr" cornell "${common[@]}" -n 6
same "--direct is accepted and renders the same film" "[0,6)" "$tmp/films/a.exr" cornell "${common[@]}" -n 6 --direct

# 2. Global iterations [5, 9): jobs starting at an iteration other than 0.
local_render render cornell "${common[@]}" -a bpt -k 5 -n 4 -q -o "$tmp/films/b.exr"
farm "--start-iteration 5" "[5,9)" "$tmp/films/b.exr" cornell "${common[@]}" -a bpt --start-iteration 5 -n 4

# 2b. upg from both sides: a worker renders its gatherings as render does (their random
#     streams are keyed by camera sub-path and vertex, not by thread), and the farm's film
#     carries the count of light vertices merged as vcm merges (the balls' specular
#     choices; farm_compare checks the counts are equal, this that there are some).
local_render render cornell "${common[@]}" -a upg --gather-from camera -k 2 -n 3 -q -o "$tmp/films/u.exr"
"$vcmfarm" info "$tmp/films/u.exr" | awk '$1 == "biased_merges" {n = $2} END {exit !(n > 0)}'
check "upg's film counts biased merges" $?
farm "upg from the camera's side" "[2,5)" "$tmp/films/u.exr" cornell "${common[@]}" -a upg --gather-from camera \
  --start-iteration 2 -n 3
# ... and the job's status says how many, as the film does.
biased=$("$vcmfarm" info --json "$tmp/films/u.exr" | jq '.biased_merges')
"$vcmfarm" status --json "${client[@]}" | jq -e --argjson n "$biased" \
  '[.jobs[] | select(.settings | test("algorithm=upg"))] | last | .biased_merges == $n and .nonfinite_samples == 0' >/dev/null
check "the job's status counts its film's biased merges" $?

# 2c. A merge radius per pixel and an orthographic camera: the worker computes the same
#     radii (a pure function of scene, camera and resolution) and renders render's film;
#     continue keeps the radius.
local_render render cornell-ortho "${common[@]}" --radius per-pixel -n 3 -q -o "$tmp/films/p.exr"
farm "a radius per pixel, orthographic" "[0,3)" "$tmp/films/p.exr" cornell-ortho "${common[@]}" --radius per-pixel -n 3
local_render render corridor "${common[@]}" -a upg --radius per-pixel -n 3 -q -o "$tmp/films/q.exr"
farm "a radius per pixel, upg in the corridor" "[0,3)" "$tmp/films/q.exr" corridor "${common[@]}" -a upg \
  --radius per-pixel -n 3
local_render continue "$tmp/films/q.exr" -n 1 -q -o "$tmp/films/q4.exr" &&
  "$vcmfarm" info "$tmp/films/q4.exr" | grep -q "radius=per-pixel"
check "continue keeps the radius per pixel" $?

# 2d. Single-stage vcm: the worker's first iteration of each lease traces the light
#     sub-paths of the iteration before again, so the farm's film of [2,6) is render's;
#     continue keeps the setting and its film is that of one render of [0,7).
local_render render cornell "${common[@]}" --vcm-stages 1 -k 2 -n 4 -q -o "$tmp/films/s.exr"
farm "single-stage vcm" "[2,6)" "$tmp/films/s.exr" cornell "${common[@]}" --vcm-stages 1 --start-iteration 2 -n 4
local_render render cornell "${common[@]}" --vcm-stages 1 -n 5 -q -o "$tmp/films/s5.exr" &&
  local_render continue "$tmp/films/s5.exr" -n 2 -q -o "$tmp/films/s7.exr" &&
  "$vcmfarm" info "$tmp/films/s7.exr" | grep -q "vcm_stages=1"
check "continue keeps single-stage" $?
same "single-stage continued is one render" "[0,7)" "$tmp/films/s7.exr" cornell "${common[@]}" --vcm-stages 1 -n 7
local_render render cornell-fog "${common[@]}" --vcm-stages 1 -n 1 -q -o "$tmp/films/fog.exr" 2>"$tmp/fog.err"
[ $? -eq 2 ] && grep -q "single-stage" "$tmp/fog.err" && [ ! -e "$tmp/films/fog.exr" ]
check "single-stage refuses participating media, exit 2, no film" $?

# 2e. Pixels sharing a light sub-path, both stages: the farm's film (the worker's pixels in
#     its 64-bit accumulator, shipped from there) is render's bit for bit; continue keeps
#     the setting and its film is that of one render.
local_render render cornell "${common[@]}" --light-path-pixels 8 -k 1 -n 3 -q -o "$tmp/films/l.exr"
farm "8 pixels a light sub-path" "[1,4)" "$tmp/films/l.exr" cornell "${common[@]}" --light-path-pixels 8 \
  --start-iteration 1 -n 3
local_render render cornell "${common[@]}" --light-path-pixels 64 --vcm-stages 1 -k 2 -n 3 -q -o "$tmp/films/l1.exr"
farm "64 pixels a light sub-path, single-stage" "[2,5)" "$tmp/films/l1.exr" cornell "${common[@]}" \
  --light-path-pixels 64 --vcm-stages 1 --start-iteration 2 -n 3
local_render render cornell "${common[@]}" --light-path-pixels 8 -n 2 -q -o "$tmp/films/l2.exr" &&
  local_render continue "$tmp/films/l2.exr" -n 2 -q -o "$tmp/films/l4.exr" &&
  "$vcmfarm" info "$tmp/films/l4.exr" | grep -q "light_path_pixels=8"
check "continue keeps the light path pixels" $?
same "light path pixels continued is one render" "[0,4)" "$tmp/films/l4.exr" cornell "${common[@]}" --light-path-pixels 8 -n 4

# 3. A JSON scene whose mesh files travel to the worker as blobs; render's film names the
#    scene file, so `continue` finds it.
scene="$source_dir/tests/scenes/good/gltf.json"
local_render render "$scene" -n 3 -q -o "$tmp/films/c.exr"
farm "JSON scene with files" "[0,3)" "$tmp/films/c.exr" "$scene" -n 3
"$vcmfarm" info "$tmp/films/c.exr" | grep -q "^scene  *$scene\$"
check "the film names the scene file" $?
local_render continue "$tmp/films/c.exr" -n 2 -q -o "$tmp/films/c5.exr" && [ "$(iterations_of "$tmp/films/c5.exr")" = "[0,5)" ]
check "continue extends it" $?

# 3b. A glTF file as the scene: the job carries the JSON that imports it, and its buffer
#     and external textures travel as blobs (a file the load reads but the job lacks
#     would fail the worker's load: "not among the job's files").
scene="$source_dir/tests/scenes/import/model.gltf"
local_render render "$scene" "${common[@]}" -n 2 -q -o "$tmp/films/gltf.exr" 2>/dev/null
check "glTF scene with external textures renders" $?
farm "glTF scene: the farm's film is render's" "[0,2)" "$tmp/films/gltf.exr" "$scene" "${common[@]}" -n 2

# 4. A target estimated error, tested after every iteration: the render stops right after
#    the iteration meeting it, so its film of [0,m) meets it and that of [0,m-1) does not.
local_render render cornell "${common[@]}" -a pt --target-error 0.08 -q -o "$tmp/films/d.exr"
m=$(end_of "$tmp/films/d.exr")
if [ -n "$m" ] && [ "$m" -ge 2 ]; then
  est=$(estimate_of "$tmp/films/d.exr")
  awk -v e="$est" 'BEGIN {exit !(e <= 0.08)}'
  check "--target-error: estimate $est <= 0.08 at $m iterations" $?
  local_render render cornell "${common[@]}" -a pt -n $((m - 1)) -q -o "$tmp/films/d-1.exr"
  before=$(estimate_of "$tmp/films/d-1.exr")
  awk -v e="$before" 'BEGIN {exit !(e > 0.08)}'
  check "--target-error: stopped right after the iteration meeting it (estimate $before at $((m - 1)))" $?
  same "--target-error: the film of [0,$m)" "[0,$m)" "$tmp/films/d.exr" cornell "${common[@]}" -a pt -n "$m"
  farm "--target-error: the farm's film of [0,$m)" "[0,$m)" "$tmp/films/d.exr" cornell "${common[@]}" -a pt -n "$m"
else
  check "--target-error: the film holds [0,m), m >= 2 (found '$m')" 1
fi

# 5. A time limit: no iteration starts after 2 s; every iteration rendered is in the film.
local_render render cornell "${common[@]}" -t 2 -q -o "$tmp/films/e.exr"
m=$(end_of "$tmp/films/e.exr")
[ -n "$m" ] && [ "$m" -gt 0 ]
check "--time 2 rendered $m iterations" $?
[ -n "$m" ] && same "--time: the film of [0,$m)" "[0,$m)" "$tmp/films/e.exr" cornell "${common[@]}" -n "$m"

# 6. SIGINT: the render finishes its iteration, writes the film and exits 0.
TMPDIR="$tmp/tmpdir" "$vcmfarm" render cornell "${common[@]}" -n 100000 --checkpoint-interval 0 -q -o "$tmp/films/f.exr" &
pid=$!
pids+=("$pid")
sleep 1.5
kill -INT "$pid"
wait "$pid"
check "SIGINT: exit status 0" $?
m=$(end_of "$tmp/films/f.exr")
[ -n "$m" ] && same "SIGINT: the film of [0,$m)" "[0,$m)" "$tmp/films/f.exr" cornell "${common[@]}" -n "$m"

# 7. SIGKILL: the output holds the last checkpoint, a valid film of [0,m), and `continue`
#    resumes it into the film of [0,m+3) (to the precision of the checkpoint's file).
TMPDIR="$tmp/tmpdir" "$vcmfarm" render cornell "${common[@]}" -n 100000 --checkpoint-interval 0.5 -q -o "$tmp/films/g.exr" &
pid=$!
pids+=("$pid")
for _ in $(seq 200); do [ -s "$tmp/films/g.exr" ] && [ "$(end_of "$tmp/films/g.exr")" ] && break; sleep 0.05; done
sleep 0.6
kill -9 "$pid"
wait "$pid" 2>/dev/null
m=$(end_of "$tmp/films/g.exr")
[ -n "$m" ] && [ "$m" -gt 0 ]
check "SIGKILL: a checkpoint of $m iterations was written" $?
if [ -n "$m" ]; then
  same "SIGKILL: the checkpoint is the film of [0,$m)" "[0,$m)" "$tmp/films/g.exr" cornell "${common[@]}" -n "$m"
  local_render continue "$tmp/films/g.exr" -n 3 -q
  check "SIGKILL: continue resumes the checkpoint" $?
  same "SIGKILL: the resumed film is that of [0,$((m + 3)))" "[0,$((m + 3)))" "$tmp/films/g.exr" cornell \
    "${common[@]}" -n $((m + 3))
fi

# 8. A reference above the old one-message limit (a film of 800x800, 59 MB) travels to the
#    farm as a blob; both films' logs hold the RMSE against it.
local_render render cornell -R 800x800 -a pt -n 1 -q -o "$tmp/films/ref.exr"
local_render render cornell -R 800x800 -a pt -n 2 -s 9 --reference "$tmp/films/ref.exr" -q -o "$tmp/films/h.exr"
check "a render against a reference of $(($(stat -c %s "$tmp/films/ref.exr") >> 20)) MiB" $?
farm "the farm's film against that reference is render's" "[0,2)" "$tmp/films/h.exr" cornell -R 800x800 -a pt -n 2 -s 9 \
  --reference "$tmp/films/ref.exr"
rmse_logged() { "$vcmfarm" info "$1" | awk 'f && NF == 7 {r = $5} /wall_s/ {f = 1} END {exit !(r != "" && r != "nan")}'; }
rmse_logged "$tmp/films/h.exr" && rmse_logged "$tmp/films/farm.exr"
check "both films' logs hold the RMSE against it" $?

# Nothing but the films: no state directory, no temporary file left.
[ -z "$(ls -A "$tmp/tmpdir")" ] && ! ls "$tmp/films" | grep -q '\.tmp\.'
check "render leaves no file beside its film: $(ls -A "$tmp/tmpdir" "$tmp/films" | tr '\n' ' ')" $?

echo "$failures failure(s)"
[ "$failures" -eq 0 ]
