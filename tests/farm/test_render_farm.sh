#!/usr/bin/env bash
# `vcmfarm render` runs an in-process coordinator and worker (cli/farm_render.c).
# Every case compares its film with `vcmfarm render --direct` of the same global
# iterations, the render loop on one thread with no farm (tests/farm/farm_compare.c: iteration
# set exactly as expected, max |difference| <= 1e-5 x image mean).
#
#   test_render_farm.sh VCMFARM FARM_COMPARE SOURCE_DIR
set -u
vcmfarm="$1"
compare="$2"
source_dir="$3"
source "$(dirname "$0")/farm_test_lib.sh"
farm_test_tmp render-farm
export TMPDIR="$tmp" # the renders' private state directories land here
failures=0
check() { # NAME STATUS
  if [ "$2" -eq 0 ]; then echo "ok   $1"; else echo "FAIL $1"; failures=$((failures + 1)); fi
}

# The iteration set of a film, as `vcmfarm info` prints it.
iterations_of() { "$vcmfarm" info "$1" | awk '$1 == "iterations" {print $2}'; }
# Its end: the N of [K,N).
end_of() { iterations_of "$1" | sed -n 's/^\[\([0-9]*\),\([0-9]*\))$/\2/p'; }

# same NAME SET FARM_FILM DIRECT_ARGS...: renders DIRECT_ARGS with --direct and compares.
same() {
  local name="$1" set="$2" film="$3"
  shift 3
  "$vcmfarm" render "$@" --direct -j 1 -q -o "$tmp/direct.exr" && "$compare" "$film" "$tmp/direct.exr" "$set"
  check "$name" $?
}

common=(-R 64x48 --seed 3)

# 1. Iterations [0, 6) with two render threads against one thread directly.
"$vcmfarm" render cornell "${common[@]}" -n 6 -j 2 -q -o "$tmp/a.exr"
check "render exits 0" $?
same "render equals render --direct" "[0,6)" "$tmp/a.exr" cornell "${common[@]}" -n 6

# 2. Global iterations [5, 9): jobs starting at an iteration other than 0.
"$vcmfarm" render cornell "${common[@]}" -a bpt -k 5 -n 4 -q -o "$tmp/b.exr"
same "--start-iteration 5" "[5,9)" "$tmp/b.exr" cornell "${common[@]}" -a bpt -k 5 -n 4

# 3. A JSON scene whose mesh files travel as blobs; the film names the scene file, so
#    `continue` finds it.
scene="$source_dir/tests/scenes/good/gltf.json"
"$vcmfarm" render "$scene" -n 3 -q -o "$tmp/c.exr"
same "JSON scene with files" "[0,3)" "$tmp/c.exr" "$scene" -n 3
"$vcmfarm" info "$tmp/c.exr" | grep -q "^scene  *$scene\$"
check "the film names the scene file" $?
"$vcmfarm" continue "$tmp/c.exr" -n 2 -q -o "$tmp/c5.exr" && [ "$(iterations_of "$tmp/c5.exr")" = "[0,5)" ]
check "continue extends it" $?

# 3b. A glTF file as the scene: the job carries the JSON that imports it, and its buffer
#     and external textures travel as blobs (a file the load reads but the job lacks
#     would fail the worker's load: "not among the job's files").
scene="$source_dir/tests/scenes/import/model.gltf"
"$vcmfarm" render "$scene" "${common[@]}" -n 2 -q -o "$tmp/gltf.exr" 2>/dev/null
check "glTF scene with external textures renders through the farm" $?
same "glTF scene through the farm equals --direct" "[0,2)" "$tmp/gltf.exr" "$scene" "${common[@]}" -n 2

# 4. A target estimated error: the job stops at the first merged part meeting it, and the
#    film holds exactly the contiguous iterations [0, m) of that part.
"$vcmfarm" render cornell "${common[@]}" -a pt --target-error 0.08 -q -o "$tmp/d.exr"
m=$(end_of "$tmp/d.exr")
if [ -n "$m" ]; then
  same "--target-error: film of [0,$m)" "[0,$m)" "$tmp/d.exr" cornell "${common[@]}" -a pt -n "$m"
  est=$("$vcmfarm" info "$tmp/d.exr" | awk '$1 == "estimated_rmse" {print $2}')
  awk -v e="$est" 'BEGIN {exit !(e <= 0.08)}'
  check "--target-error: estimate $est <= 0.08 at $m iterations" $?
else
  check "--target-error: film holds [0,m)" 1
fi

# 5. A time limit: no new iteration after 2 s; what was rendered is shipped, and counted.
"$vcmfarm" render cornell "${common[@]}" -t 2 -q -o "$tmp/e.exr"
m=$(end_of "$tmp/e.exr")
[ -n "$m" ] && [ "$m" -gt 0 ]
check "--time 2 rendered $m iterations" $?
[ -n "$m" ] && same "--time: film of [0,$m)" "[0,$m)" "$tmp/e.exr" cornell "${common[@]}" -n "$m"

# 6. SIGINT: the render ships what it has, writes the film and exits 0.
"$vcmfarm" render cornell "${common[@]}" -n 100000 -q -o "$tmp/f.exr" &
pid=$!
pids+=("$pid")
for _ in $(seq 100); do [ -d "$tmp"/vcmfarm-render-* ] 2>/dev/null && break; sleep 0.05; done
sleep 1.5
kill -INT "$pid"
wait "$pid"
check "SIGINT: exit status 0" $?
m=$(end_of "$tmp/f.exr")
[ -n "$m" ] && same "SIGINT: film of [0,$m)" "[0,$m)" "$tmp/f.exr" cornell "${common[@]}" -n "$m"
ls -d "$tmp"/vcmfarm-render-* >/dev/null 2>&1
check "the private state directories are removed" $((!$?))

# 7. SIGKILL: the output holds the last checkpoint, a valid film of [0, m).
rm -f "$tmp/g.exr" # step 3's film of another scene: the wait below must see this render's
"$vcmfarm" render cornell "${common[@]}" -n 100000 --checkpoint-interval 0.5 -q -o "$tmp/g.exr" &
pid=$!
pids+=("$pid")
# A checkpoint holding a part (the first lease is bounded by time, its first part shipped
# after the worker's ship interval of 1 s; checkpoints before it hold no iteration), then
# one more interval.
for _ in $(seq 200); do [ -s "$tmp/g.exr" ] && [ "$(end_of "$tmp/g.exr")" ] && break; sleep 0.05; done
sleep 0.6
kill -9 "$pid"
wait "$pid" 2>/dev/null
m=$(end_of "$tmp/g.exr")
[ -n "$m" ] && [ "$m" -gt 0 ]
check "SIGKILL: a checkpoint of $m iterations was written" $?
[ -n "$m" ] && same "SIGKILL: the checkpoint is the film of [0,$m)" "[0,$m)" "$tmp/g.exr" cornell "${common[@]}" -n "$m"

# 8. A reference above the old one-message limit (a film of 800x800, 59 MB) travels as a
#    blob; the film's log holds the RMSE against it.
"$vcmfarm" render cornell -R 800x800 -a pt -n 1 --direct -q -o "$tmp/ref.exr"
"$vcmfarm" render cornell -R 800x800 -a pt -n 2 -s 9 --reference "$tmp/ref.exr" -q -o "$tmp/h.exr"
check "a reference of $(($(stat -c %s "$tmp/ref.exr") >> 20)) MiB" $?
"$vcmfarm" info "$tmp/h.exr" | awk 'f && NF == 7 {r = $5} /wall_s/ {f = 1} END {exit !(r != "" && r != "nan")}'
check "the film's log holds the RMSE against it" $?

echo "$failures failure(s)"
[ "$failures" -eq 0 ]
