#!/usr/bin/env bash
# The command line as a user meets it: every broken scene is refused with exit status 2, a
# message naming the file, the field and the problem, and no output file; bad options
# likewise; --help and --version work.
set -u
vcmfarm="$1"
scenes="$2"
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
passed=0
failed=0
skipped=0

check() { # name, condition result (0 = pass)
  if [ "$2" -eq 0 ]; then passed=$((passed + 1)); echo "ok   $1"; else failed=$((failed + 1)); echo "FAIL $1"; fi
}

expect_refusal() { # name, expected substring, command...
  local name="$1" expected="$2"
  shift 2
  rm -f "$tmp/out.exr"
  "$@" >"$tmp/stdout" 2>"$tmp/stderr"
  local status=$?
  local ok=0
  [ "$status" -eq 2 ] || { echo "  exit status $status, expected 2"; ok=1; }
  grep -qF -- "$expected" "$tmp/stderr" || { echo "  stderr lacks '$expected':"; sed 's/^/    /' "$tmp/stderr"; ok=1; }
  [ ! -e "$tmp/out.exr" ] || { echo "  an output file was written"; ok=1; }
  check "$name" $ok
}

while IFS=$'\t' read -r file expected; do
  [ -n "$file" ] || continue
  expect_refusal "bad scene $file" "$expected" "$vcmfarm" render "$scenes/bad/$file" -n 1 -R 8x8 -o "$tmp/out.exr"
done <"$scenes/bad/EXPECTED.txt"

expect_refusal "missing scene file" "no-such-scene.json" "$vcmfarm" render no-such-scene.json -n 1 -o "$tmp/out.exr"
expect_refusal "unknown algorithm" "unknown algorithm 'mlt'" "$vcmfarm" render furnace -a mlt -o "$tmp/out.exr"
expect_refusal "zero resolution" "--resolution" "$vcmfarm" render furnace -R 0x10 -o "$tmp/out.exr"
expect_refusal "negative iterations" "--iterations" "$vcmfarm" render furnace -n -3 -o "$tmp/out.exr"
expect_refusal "iterations and time" "not both" "$vcmfarm" render furnace -n 3 -t 2 -o "$tmp/out.exr"
expect_refusal "alpha out of range" "--alpha" "$vcmfarm" render furnace --alpha 1.5 -o "$tmp/out.exr"
expect_refusal "MIS beta below 1" "--mis-beta" "$vcmfarm" render furnace --mis-beta 0.5 -o "$tmp/out.exr"
expect_refusal "MIS beta above 4" "--mis-beta" "$vcmfarm" render furnace --mis-beta 5 -o "$tmp/out.exr"
# Films of different MIS exponents are different estimators: they never merge.
"$vcmfarm" render furnace -R 8x8 -n 1 -q -o "$tmp/beta1.exr" &&
  "$vcmfarm" render furnace -R 8x8 -n 1 -k 1 --mis-beta 2 -q -o "$tmp/beta2.exr"
check "films of MIS beta 1 and 2 rendered" $?
expect_refusal "films of MIS beta 1 and 2 do not merge" "mis_beta=2" "$vcmfarm" merge -o "$tmp/out.exr" "$tmp/beta1.exr" "$tmp/beta2.exr"
# A merge radius per pixel: an option of the algorithms that merge, recorded in the film
# (so that it refuses to merge with a film of one radius), described by the render.
expect_refusal "unknown merge radius" "unknown merge radius 'local'" "$vcmfarm" render furnace --radius local -o "$tmp/out.exr"
expect_refusal "radius per pixel without merging" "option of the algorithms that merge" "$vcmfarm" render furnace -a bpt --radius per-pixel -o "$tmp/out.exr"
"$vcmfarm" render furnace -R 8x8 -n 1 -k 1 --radius per-pixel -v -o "$tmp/pixel.exr" 2>"$tmp/stderr"
check "radius per pixel renders" $?
check "radius per pixel described" "$(grep -q "^merge radius: per pixel, from" "$tmp/stderr"; echo $?)"
check "radius per pixel in the film's settings" "$("$vcmfarm" info "$tmp/pixel.exr" | grep -q "radius=per-pixel"; echo $?)"
expect_refusal "films of one radius and of a radius per pixel do not merge" "radius=per-pixel" "$vcmfarm" merge -o "$tmp/out.exr" "$tmp/beta1.exr" "$tmp/pixel.exr"
# Single-stage vcm: 1 or 2, an option of vcm (and auto), recorded in the film, described.
expect_refusal "vcm stages out of range" "--vcm-stages" "$vcmfarm" render furnace --vcm-stages 3 -o "$tmp/out.exr"
expect_refusal "single-stage without vcm" "option of vcm" "$vcmfarm" render furnace -a bpt --vcm-stages 1 -o "$tmp/out.exr"
"$vcmfarm" render furnace -R 8x8 -n 1 -k 1 --vcm-stages 1 -v -o "$tmp/stage1.exr" 2>"$tmp/stderr"
check "single-stage renders" $?
check "single-stage described" "$(grep -q "^single-stage (--vcm-stages 1)" "$tmp/stderr"; echo $?)"
check "single-stage in the film's settings" "$("$vcmfarm" info "$tmp/stage1.exr" | grep -q "vcm_stages=1"; echo $?)"
expect_refusal "films of one and two stages do not merge" "vcm_stages=1" "$vcmfarm" merge -o "$tmp/out.exr" "$tmp/beta1.exr" "$tmp/stage1.exr"
# Pixels sharing a light sub-path: a power of two up to 1024, named when wrong (exit 2), not
# for pt or upg, recorded in the film, described; films of different values do not merge.
expect_refusal "light path pixels not a power of two" "--light-path-pixels: '6' is not a power of two" "$vcmfarm" render furnace --light-path-pixels 6 -o "$tmp/out.exr"
expect_refusal "light path pixels out of range" "--light-path-pixels" "$vcmfarm" render furnace --light-path-pixels 2048 -o "$tmp/out.exr"
expect_refusal "light path pixels not a number" "--light-path-pixels" "$vcmfarm" render furnace --light-path-pixels eight -o "$tmp/out.exr"
expect_refusal "light path pixels with upg" "not of upg" "$vcmfarm" render furnace -a upg --light-path-pixels 8 -o "$tmp/out.exr"
"$vcmfarm" render furnace -R 8x8 -n 1 -k 1 --light-path-pixels 8 -v -o "$tmp/lpp.exr" 2>"$tmp/stderr"
check "light path pixels renders" $?
check "light path pixels described" "$(grep -q "^light sub-paths (--light-path-pixels 8): one per block of 4x2 pixels, 8 an iteration" "$tmp/stderr"; echo $?)"
check "light path pixels in the film's settings" "$("$vcmfarm" info "$tmp/lpp.exr" | grep -q "light_path_pixels=8"; echo $?)"
expect_refusal "films of different light path pixels do not merge" "light_path_pixels=8" "$vcmfarm" merge -o "$tmp/out.exr" "$tmp/beta1.exr" "$tmp/lpp.exr"
# A pilot (common/allocation.h): at least 2 iterations, pt, bpt, vcm and auto only, named
# when wrong (exit 2); the render says what it allocated, the film keeps it (info shows
# it); films of other pilots do not merge; a farm job refuses what render refuses (below,
# with the key; tests/farm/test_farm_pilot.sh runs farm jobs with a pilot).
# test_exact.sh continues such a film.
expect_refusal "pilot of one iteration" "--pilot: a pilot needs at least 2 iterations" "$vcmfarm" render furnace --pilot 1 -o "$tmp/out.exr"
expect_refusal "pilot not a number" "--pilot" "$vcmfarm" render furnace --pilot ten -o "$tmp/out.exr"
expect_refusal "pilot with lt" "not of lt" "$vcmfarm" render furnace -a lt --pilot 8 -o "$tmp/out.exr"
expect_refusal "pilot with single-stage vcm" "not of the single-stage one" "$vcmfarm" render furnace --vcm-stages 1 --pilot 8 -o "$tmp/out.exr"
"$vcmfarm" render cornell -R 24x16 -n 6 --pilot 4 -o "$tmp/pilot6.exr" 2>"$tmp/stderr"
check "pilot renders" $?
check "pilot reported" "$(grep -q "^pilot: 4 iterations in" "$tmp/stderr" && grep -q "^allocation from the pilot: [0-9.]* camera sub-paths a pixel on average" "$tmp/stderr"; echo $?)"
check "pilot in the film's settings" "$("$vcmfarm" info "$tmp/pilot6.exr" | grep -q " pilot=4"; echo $?)"
check "allocation in info" "$("$vcmfarm" info --json "$tmp/pilot6.exr" | jq -e '.allocation.mean_camera_sub_paths >= 1 and (.allocation.pixels_of_1_2_4_8_16 | add) == 384' >/dev/null; echo $?)"
"$vcmfarm" render cornell -R 24x16 -n 2 --pilot 8 -q -o "$tmp/pilot8.exr"
expect_refusal "films of different pilots do not merge" "pilot=8" "$vcmfarm" merge -o "$tmp/out.exr" "$tmp/pilot6.exr" "$tmp/pilot8.exr"
# --allocation-from FILM: FILM's allocation instead of a pilot, for a render of FILM's size
# and pilot (its pilot by default), so the film is the one the pilot would have given; a film
# without one, of another scene, size or pilot is refused naming it, for render and for submit
# (below, with the key: before anything is sent).
"$vcmfarm" render cornell -R 24x16 -n 6 --allocation-from "$tmp/pilot6.exr" -o "$tmp/from6.exr" 2>"$tmp/stderr"
check "--allocation-from renders" $?
check "--allocation-from renders no pilot" "$(! grep -q "^pilot: " "$tmp/stderr"; echo $?)"
check "--allocation-from takes FILM's pilot and allocation" "$("$vcmfarm" info "$tmp/from6.exr" | grep -q " pilot=4" &&
  [ "$("$vcmfarm" info "$tmp/from6.exr" | grep '^allocation ')" = "$("$vcmfarm" info "$tmp/pilot6.exr" | grep '^allocation ')" ]; echo $?)"
same_image() { "$vcmfarm" info "$1" | grep '^image_mean\|^estimated_rmse\|^iterations '; }
check "--allocation-from gives the film of the pilot's allocation" "$([ "$(same_image "$tmp/pilot6.exr")" = "$(same_image "$tmp/from6.exr")" ]; echo $?)"
expect_refusal "--allocation-from a film without an allocation" "--allocation-from $tmp/beta1.exr: the film has no allocation of camera sub-paths" \
  "$vcmfarm" render cornell -R 24x16 --allocation-from "$tmp/beta1.exr" -o "$tmp/out.exr"
expect_refusal "--allocation-from a film of another size" "--allocation-from $tmp/pilot6.exr: the film is 24x16, this render 32x16" \
  "$vcmfarm" render cornell -R 32x16 --allocation-from "$tmp/pilot6.exr" -o "$tmp/out.exr"
expect_refusal "--allocation-from a film of another pilot" "--allocation-from $tmp/pilot6.exr: its allocation comes from a pilot of 4 iterations, this render's pilot is 8" \
  "$vcmfarm" render cornell -R 24x16 --pilot 8 --allocation-from "$tmp/pilot6.exr" -o "$tmp/out.exr"
expect_refusal "--allocation-from a film of another scene" "--allocation-from $tmp/pilot6.exr: the film was rendered from another scene" \
  "$vcmfarm" render cornell-glossy -R 24x16 --allocation-from "$tmp/pilot6.exr" -o "$tmp/out.exr"
expect_refusal "--allocation-from a missing film" "--allocation-from $tmp/absent.exr" \
  "$vcmfarm" render cornell -R 24x16 --allocation-from "$tmp/absent.exr" -o "$tmp/out.exr"
# upg: its side is an option of upg alone, named when wrong; its render counts its
# gatherings; a film says what its estimated RMSE covers.
expect_refusal "unknown gathering side" "unknown side 'eye'" "$vcmfarm" render furnace -a upg --gather-from eye -o "$tmp/out.exr"
expect_refusal "gathering side without upg" "option of upg, not of vcm" "$vcmfarm" render furnace --gather-from camera -o "$tmp/out.exr"
"$vcmfarm" render cornell-diffuse -R 16x16 -n 2 -a upg --gather-from camera -o "$tmp/upg.exr" 2>"$tmp/stderr"
check "upg renders" $?
check "upg counts its gatherings" "$(grep -q "^gathering: [0-9]* light vertices without bias" "$tmp/stderr"; echo $?)"
check "upg's film: settings" "$("$vcmfarm" info "$tmp/upg.exr" | grep -q "algorithm=upg .* gather=camera"; echo $?)"
check "upg's estimate covers the error" "$("$vcmfarm" info --json "$tmp/upg.exr" | jq -e '.estimate_covers == "error"' >/dev/null; echo $?)"
check "vcm's estimate covers the variance" "$("$vcmfarm" info --json "$tmp/beta1.exr" | jq -e '.estimate_covers == "variance"' >/dev/null; echo $?)"
# upg merges as vcm the light vertices it cannot gather (a mirror or glass ball's ideal
# specular choices), and its film counts them: the cornell box's balls make some at a
# radius of 0.1 (none at the default radius in 2 iterations of 16x16), the all-diffuse box
# none. info's sentence on the estimate names the count.
"$vcmfarm" render cornell -R 16x16 -n 2 -a upg -r 0.1 -q -o "$tmp/upg-balls.exr"
check "upg renders the balls" $?
check "upg's film counts its biased merges" "$("$vcmfarm" info --json "$tmp/upg-balls.exr" | jq -e '.biased_merges > 0' >/dev/null; echo $?)"
check "upg's estimate covers the error but those merges" "$("$vcmfarm" info "$tmp/upg-balls.exr" | grep -q "^estimate_covers  *the error, except the bias of the [0-9]* light vertices merged as vcm"; echo $?)"
biased_of() { "$vcmfarm" info --json "$1" | jq -r '.biased_merges'; }
"$vcmfarm" render cornell -R 16x16 -n 2 -k 2 -a upg -r 0.1 -q -o "$tmp/upg-balls2.exr" &&
  "$vcmfarm" merge -q -o "$tmp/upg-balls-merged.exr" "$tmp/upg-balls.exr" "$tmp/upg-balls2.exr"
check "merged upg films add their biased merges" "$([ "$(biased_of "$tmp/upg-balls-merged.exr")" -eq $(($(biased_of "$tmp/upg-balls.exr") + $(biased_of "$tmp/upg-balls2.exr"))) ]; echo $?)"
"$vcmfarm" render cornell-diffuse -R 16x16 -n 2 -a upg -r 0.1 -q -o "$tmp/upg-diffuse.exr"
check "upg renders the diffuse box" $?
check "upg merges nothing biased in a diffuse box" "$("$vcmfarm" info --json "$tmp/upg-diffuse.exr" | jq -e '.biased_merges == 0' >/dev/null; echo $?)"
check "a vcm film counts no biased merges" "$("$vcmfarm" info "$tmp/beta1.exr" | grep -q "^biased_merges  *0$"; echo $?)"
"$vcmfarm" render cornell-rough -R 16x16 -n 1 -a auto-unbiased -o "$tmp/au.exr" 2>"$tmp/stderr"
check "auto-unbiased names its choice" "$(head -1 "$tmp/stderr" | grep -q "upg (auto-unbiased)"; echo $?)"
# A bad option is refused on one line naming it, with a hint, not under the whole --help;
# every subcommand alike.
expect_one_line() { # name, expected substring, command...
  local name="$1"
  expect_refusal "$@"
  check "$name: one line" "$([ "$(wc -l <"$tmp/stderr")" -eq 1 ]; echo $?)"
}
expect_one_line "unknown option" "vcmfarm render: unknown option '--frobnicate'; try 'vcmfarm render --help'" \
  "$vcmfarm" render furnace --frobnicate -o "$tmp/out.exr"
for c in render continue info plot merge bake errors diff coordinator worker submit status fetch cancel pause resume remove keygen; do
  expect_one_line "$c: unknown option" "vcmfarm $c: unknown option '--frobnicate'; try 'vcmfarm $c --help'" \
    "$vcmfarm" "$c" --frobnicate
done
expect_one_line "unknown command" "vcmfarm: unknown command 'rendr' (did you mean render?); try 'vcmfarm --help'" \
  "$vcmfarm" rendr furnace
expect_one_line "missing operand" "vcmfarm render: expected exactly one SCENE; try 'vcmfarm render --help'" \
  "$vcmfarm" render -o "$tmp/out.exr"
expect_one_line "option without its value" "vcmfarm render: option '--output' needs a value" "$vcmfarm" render furnace --output
expect_one_line "keygen with an option for a file" "vcmfarm keygen: unknown option '--force'" "$vcmfarm" keygen --force
check "keygen wrote no file named like an option" "$([ ! -e ./--force ]; echo $?)"
# Long options are matched exactly: a prefix is not taken for the option it begins.
expect_one_line "a prefix of --iterations" "unknown option '--iteration' (did you mean --iterations?)" \
  "$vcmfarm" render furnace --iteration 4 -o "$tmp/out.exr"
expect_one_line "a prefix, with =" "unknown option '--iter' (did you mean --iterations?)" \
  "$vcmfarm" render furnace --iter=4 -o "$tmp/out.exr"
expect_one_line "a typo of --iterations" "unknown option '--iteratons' (did you mean --iterations?)" \
  "$vcmfarm" continue "$tmp/none.exr" --iteratons 4
expect_one_line "a prefix of --coordinator" "vcmfarm submit: unknown option '--coord' (did you mean --coordinator?)" \
  "$vcmfarm" submit furnace --coord ipc://x --secret x
expect_one_line "a prefix of two options" "unknown option '--re' (did you mean --reference or --resolution?)" \
  "$vcmfarm" render furnace --re 8x8 -o "$tmp/out.exr"
expect_one_line "a long option with one dash" "unknown option '-d' (did you mean --direct?)" \
  "$vcmfarm" render furnace -direct -o "$tmp/out.exr"
# One iteration has no spread to estimate its error from: said so, not printed as nan.
"$vcmfarm" render furnace --direct -n 1 -R 8x8 -o "$tmp/one.exr" 2>"$tmp/stderr"
check "one iteration: the estimate is not known yet, not nan" \
  "$(grep -q 'estimated RMSE not known yet' "$tmp/stderr" && ! grep -qi 'nan' "$tmp/stderr"; echo $?)"
expect_refusal "missing output" "missing -o" "$vcmfarm" render furnace -n 1
# An output that cannot be written is refused before rendering, with and without --direct.
expect_refusal "output in a missing directory" "no directory $tmp/absent" "$vcmfarm" render furnace -n 1 -o "$tmp/absent/out.exr"
expect_refusal "output is a directory" "is a directory" "$vcmfarm" render furnace --direct -n 1 -o "$tmp"
expect_refusal "preview in a missing directory" "--preview" "$vcmfarm" render furnace -n 1 -o "$tmp/out.exr" -p "$tmp/absent/p.png"
# A file is never written under a name that says another format.
expect_refusal "film named .png" "does not end in .exr" "$vcmfarm" render furnace -n 1 -o "$tmp/film.png"
expect_refusal "preview named .exr" "does not end in .png" "$vcmfarm" render furnace -n 1 -o "$tmp/out.exr" -p "$tmp/p.exr"
expect_refusal "plot named .svg" "does not end in .png" "$vcmfarm" plot "$tmp/any.exr" -o "$tmp/p.svg"
# A misspelt built-in scene lists the built-in names, with and without --direct.
expect_refusal "misspelt built-in" "not a built-in scene either (built-in: cornell," "$vcmfarm" render cornel -n 1 -o "$tmp/out.exr"
expect_refusal "misspelt built-in, --direct" "built-in: cornell," "$vcmfarm" render cornel --direct -n 1 -o "$tmp/out.exr"
expect_refusal "unknown command" "unknown command" "$vcmfarm" frobnicate
expect_refusal "cache size not a size" "--cache-max: '12Q' is not a size" "$vcmfarm" worker --connect ipc://x --secret x --cache-max 12Q

# The roles' directories and sockets are never taken from someone else.
"$vcmfarm" keygen "$tmp/farm.key" >/dev/null 2>&1
echo "a user's file" >"$tmp/regular"
# An address without its scheme is refused saying what to write, not "Invalid argument".
expect_one_line "--coordinator without tcp://" \
  "vcmfarm status: --coordinator 127.0.0.1:7450: an address starts with its scheme: write tcp://127.0.0.1:7450" \
  "$vcmfarm" status --coordinator 127.0.0.1:7450 --secret "$tmp/farm.key"
expect_one_line "--connect of a socket file without ipc://" "--connect $tmp/c.sock: an address starts with its scheme: write ipc://$tmp/c.sock" \
  "$vcmfarm" worker --connect "$tmp/c.sock" --secret "$tmp/farm.key"
expect_one_line "--listen of another scheme" "--listen http://127.0.0.1:7450: unknown scheme 'http://'; write tcp://HOST:PORT or ipc://PATH" \
  "$vcmfarm" coordinator --listen http://127.0.0.1:7450 --state "$tmp/state-x" --secret "$tmp/farm.key"
expect_one_line "tcp:// without a port" "--coordinator tcp://127.0.0.1: a tcp:// address is tcp://HOST:PORT, with a port number" \
  "$vcmfarm" fetch 1 -o "$tmp/f.exr" --coordinator tcp://127.0.0.1 --secret "$tmp/farm.key"
expect_one_line "inproc:// from another process" "--coordinator inproc://farm: inproc:// reaches only a coordinator inside the same process" \
  "$vcmfarm" cancel 1 --coordinator inproc://farm --secret "$tmp/farm.key"
expect_refusal "ipc:// path that is a regular file" "is not a socket; refusing to replace it" \
  timeout 20 "$vcmfarm" coordinator --listen "ipc://$tmp/regular" --state "$tmp/state-a" --secret "$tmp/farm.key"
grep -q "a user's file" "$tmp/regular"
check "the regular file is kept" $?
"$vcmfarm" coordinator --listen "ipc://$tmp/live.sock" --state "$tmp/state-live" --secret "$tmp/farm.key" 2>/dev/null &
live=$!
for _ in $(seq 100); do [ -S "$tmp/live.sock" ] && [ -e "$tmp/state-live/lock" ] && break; sleep 0.05; done
expect_refusal "ipc:// socket another coordinator listens on" "another process listens on" \
  timeout 20 "$vcmfarm" coordinator --listen "ipc://$tmp/live.sock" --state "$tmp/state-b" --secret "$tmp/farm.key"
expect_refusal "worker cache in a coordinator's state directory" "is a coordinator's state directory" \
  timeout 20 "$vcmfarm" worker --connect "ipc://$tmp/live.sock" --secret "$tmp/farm.key" --cache "$tmp/state-live" --cache-max 1
# A wrong key and a coordinator that is down are told apart at once (the coordinator
# answers a request it cannot authenticate with a fixed refusal; nothing accepting the
# connection means nobody is there): each in well under a second on an idle machine, 2 s
# allowed here for a busy one, where --timeout would have waited 10 s for either.
expect_quick() { # name, expected exit status, expected substring, command...
  local name="$1" want="$2" expected="$3"
  shift 3
  local start=${EPOCHREALTIME/./}
  timeout 20 "$@" >"$tmp/stdout" 2>"$tmp/stderr"
  local status=$? ms=$(((${EPOCHREALTIME/./} - start) / 1000)) ok=0
  [ "$status" -eq "$want" ] || { echo "  exit status $status, expected $want"; ok=1; }
  grep -qF -- "$expected" "$tmp/stderr" || { echo "  stderr lacks '$expected':"; sed 's/^/    /' "$tmp/stderr"; ok=1; }
  [ "$ms" -le 2000 ] || { echo "  took $ms ms"; ok=1; }
  check "$name ($ms ms)" $ok
}
"$vcmfarm" keygen "$tmp/other.key" >/dev/null 2>&1
expect_quick "status with another key" 2 \
  "vcmfarm status: the coordinator at ipc://$tmp/live.sock refused the key (wrong --secret?)" \
  "$vcmfarm" status --coordinator "ipc://$tmp/live.sock" --secret "$tmp/other.key"
expect_quick "worker with another key stops" 2 "vcmfarm worker: the coordinator at ipc://$tmp/live.sock refused the key" \
  "$vcmfarm" worker --connect "ipc://$tmp/live.sock" --secret "$tmp/other.key" --cache "$tmp/other-cache"
expect_quick "status of a coordinator that is down" 1 \
  "vcmfarm status: no coordinator answered at ipc://$tmp/down.sock (nothing accepts connections there)" \
  "$vcmfarm" status --coordinator "ipc://$tmp/down.sock" --secret "$tmp/farm.key"
expect_quick "a farm job's pilot refuses what render's does" 2 "a pilot (camera sub-paths allocated per pixel) is an option of pt, bpt, vcm and auto, not of lt" \
  "$vcmfarm" submit furnace -a lt --pilot 8 --coordinator "ipc://$tmp/live.sock" --secret "$tmp/farm.key"
expect_quick "a farm job's pilot refuses single-stage vcm" 2 "not of the single-stage one" \
  "$vcmfarm" submit furnace --vcm-stages 1 --pilot 8 --coordinator "ipc://$tmp/live.sock" --secret "$tmp/farm.key"
expect_quick "submit --allocation-from a film of another pilot" 2 "--allocation-from $tmp/pilot6.exr: its allocation comes from a pilot of 4 iterations, this render's pilot is 8" \
  "$vcmfarm" submit cornell -R 24x16 --pilot 8 --allocation-from "$tmp/pilot6.exr" --coordinator "ipc://$tmp/live.sock" --secret "$tmp/farm.key"
expect_quick "submit --allocation-from a film of another size" 2 "--allocation-from $tmp/pilot6.exr: the film is 24x16, this render 16x16" \
  "$vcmfarm" submit cornell -R 16x16 --allocation-from "$tmp/pilot6.exr" --coordinator "ipc://$tmp/live.sock" --secret "$tmp/farm.key"
expect_quick "submit --allocation-from a film of another scene" 2 "--allocation-from $tmp/pilot6.exr: the film was rendered from another scene" \
  "$vcmfarm" submit cornell-glossy -R 24x16 --allocation-from "$tmp/pilot6.exr" --coordinator "ipc://$tmp/live.sock" --secret "$tmp/farm.key"
expect_quick "submit --allocation-from a film without an allocation" 2 "--allocation-from $tmp/beta1.exr: the film has no allocation of camera sub-paths" \
  "$vcmfarm" submit cornell -R 24x16 --allocation-from "$tmp/beta1.exr" --coordinator "ipc://$tmp/live.sock" --secret "$tmp/farm.key"
expect_quick "submit to a coordinator that is down, over tcp://" 1 "no coordinator answered at tcp://127.0.0.1:1 " \
  "$vcmfarm" submit furnace --coordinator tcp://127.0.0.1:1 --secret "$tmp/farm.key"
kill -TERM "$live" && wait "$live"
mkdir -p "$tmp/cache" && touch "$tmp/cache/vcmfarm-worker-cache"
expect_refusal "coordinator state in a worker's cache" "is a worker's scene-file cache" \
  timeout 20 "$vcmfarm" coordinator --listen "ipc://$tmp/c.sock" --state "$tmp/cache" --secret "$tmp/farm.key"

"$vcmfarm" --version | grep -q '^vcmfarm [0-9]'
check "--version" $?
# The install rule (README, "Set-up"): cmake --install puts the executable in PREFIX/bin ...
cmake --install "$(dirname "$vcmfarm")" --prefix "$tmp/prefix" >"$tmp/install.log" 2>&1
installed=$?
check "cmake --install puts vcmfarm in PREFIX/bin" "$([ "$installed" -eq 0 ] && cmp -s "$vcmfarm" "$tmp/prefix/bin/vcmfarm" &&
  "$tmp/prefix/bin/vcmfarm" --version | grep -q '^vcmfarm [0-9]'; echo $?)"
# ... and the modules (common/module.h) in PREFIX/lib/vcmfarm, where the installed vcmfarm
# loads them from (LD_DEBUG=files names every object the loader maps), each only when a
# command needs it: OpenVDB for a density grid, Embree to trace rays, cairo to draw.
modules_installed=0
for m in "$(dirname "$vcmfarm")"/libvf_*.so; do
  cmp -s "$m" "$tmp/prefix/lib/vcmfarm/$(basename "$m")" && modules_installed=$((modules_installed + 1))
done
check "cmake --install puts the modules in PREFIX/lib/vcmfarm ($modules_installed of 5)" "$([ "$modules_installed" -eq 5 ]; echo $?)"
LD_DEBUG=files "$tmp/prefix/bin/vcmfarm" render cornell-smoke -R 8x8 -n 1 -q -o "$tmp/smoke.exr" >"$tmp/smoke.files" 2>&1
check "the installed vcmfarm loads its OpenVDB and Embree modules from PREFIX/lib/vcmfarm" "$(
  grep -q "file=$tmp/prefix/bin/../lib/vcmfarm/libvf_vdb.so " "$tmp/smoke.files" &&
  grep -q "file=$tmp/prefix/bin/../lib/vcmfarm/libvf_embree.so " "$tmp/smoke.files"; echo $?)"
LD_DEBUG=files "$vcmfarm" render cornell -R 8x8 -n 1 -q -o "$tmp/plain.exr" >"$tmp/plain.files" 2>&1
check "a render without grids, meshes or drawings loads Embree and nothing else optional" "$(
  grep -q "libembree3" "$tmp/plain.files" && ! grep -q -E "libopenvdb|libassimp|libcairo|libmicrohttpd" "$tmp/plain.files"
  echo $?)"
LD_DEBUG=files "$vcmfarm" info "$tmp/plain.exr" >"$tmp/info.files" 2>&1
check "info loads no module" "$(! grep -q -E "libvf_|libembree3|libopenvdb|libassimp|libcairo|libmicrohttpd" "$tmp/info.files"; echo $?)"
# A module missing from every place it is looked for (the installed program without its
# Embree module, the build tree hidden by a mount namespace of the check's own): the command
# that needs it fails with exit 1, naming the module and the places; one that does not,
# works.
if [ "$(id -u)" -eq 0 ] && command -v unshare >/dev/null; then
  rm -f "$tmp/prefix/lib/vcmfarm/libvf_embree.so"
  without_build_tree() { # command...: run with the build tree hidden
    unshare --mount bash -c 'mount -t tmpfs none "$0" && exec "$@"' "$(dirname "$vcmfarm")" "$@"
  }
  without_build_tree "$tmp/prefix/bin/vcmfarm" render cornell -R 8x8 -n 1 -q -o "$tmp/nomodule.exr" 2>"$tmp/nomodule.err"
  status=$?
  check "a render without its Embree module: exit 1 naming it and where it was looked for" "$([ "$status" -eq 1 ] &&
    grep -q "cannot trace rays: Embree ray tracing (libvf_embree.so) is not installed: looked in .*/prefix/bin/../lib/vcmfarm/libvf_embree.so" \
      "$tmp/nomodule.err" && [ ! -e "$tmp/nomodule.exr" ]; echo $?)"
  without_build_tree "$tmp/prefix/bin/vcmfarm" info "$tmp/plain.exr" >/dev/null
  check "info without the Embree module" $?
else
  echo "note: not root or no unshare: the missing-module case is left out"
fi
"$vcmfarm" render --help | grep -q 'usage: vcmfarm render'
check "render --help" $?
# submit takes every kind of scene render takes, and its --help says so.
"$vcmfarm" submit --help >"$tmp/submit-help.txt"
check "submit --help names every kind of scene" "$([ $? -eq 0 ] && tr '\n' ' ' <"$tmp/submit-help.txt" |
  grep -q 'SCENE is a built-in name .* a JSON scene file, a glTF 2.0 file (.gltf, .glb), an OBJ file .* or a Mitsuba 3 scene (.xml)'; echo $?)"

"$vcmfarm" render furnace -n 2 -R 16x16 -q -o "$tmp/ok.exr" -p "$tmp/ok.png"
check "good render writes film and preview" $([ -s "$tmp/ok.exr" ] && [ -s "$tmp/ok.png" ]; echo $?)
# A film with one flipped bit is refused by every reader (its checksum), with exit 2.
cp "$tmp/ok.exr" "$tmp/flipped.exr"
size=$(stat -c %s "$tmp/flipped.exr")
byte=$(od -An -tu1 -j $((size - 100)) -N1 "$tmp/flipped.exr" | tr -d ' ')
printf "$(printf '\\%03o' $((byte ^ 4)))" | dd of="$tmp/flipped.exr" bs=1 seek=$((size - 100)) conv=notrunc status=none
expect_refusal "info refuses a film with a flipped bit" "flipped.exr: damaged: its checksum does not match its contents" \
  "$vcmfarm" info "$tmp/flipped.exr"
expect_refusal "continue refuses a film with a flipped bit" "flipped.exr: damaged" \
  "$vcmfarm" continue "$tmp/flipped.exr" -n 1 -o "$tmp/out.exr"

# glTF import (tests/scenes/import: the file tests/worker/scene/test_import.c writes, with external
# textures): notes at load, --camera, and broken copies refused naming file and problem.
import="$scenes/import"
"$vcmfarm" render "$import/model.gltf" --direct -n 1 -R 16x12 -q -o "$tmp/gltf.exr" 2>"$tmp/stderr"
check "glTF scene renders" $([ -s "$tmp/gltf.exr" ]; echo $?)
grep -qF "model.gltf: note: extension KHR_materials_iridescence is not supported" "$tmp/stderr"
check "glTF notes are printed once at load" $([ "$(grep -c KHR_materials_iridescence "$tmp/stderr")" -eq 1 ]; echo $?)
"$vcmfarm" render "$import/model.gltf" --camera TopCam -n 1 -R 16x12 -q -o "$tmp/top.exr"
check "--camera by name" $([ -s "$tmp/top.exr" ]; echo $?)
expect_refusal "unknown --camera" "--camera: no camera 'Nope' in model.gltf (its cameras: 0 'CamNode', 1 'TopCam')" \
  "$vcmfarm" render "$import/model.gltf" --camera Nope -n 1 -R 8x8 -o "$tmp/out.exr"
expect_refusal "--camera with a built-in scene" "--camera chooses a camera of a glTF or OBJ file" \
  "$vcmfarm" render furnace --camera 0 -n 1 -R 8x8 -o "$tmp/out.exr"
broken="$tmp/broken"
fresh_copy() { rm -rf "$broken"; mkdir "$broken"; cp "$import"/* "$broken"/; }
fresh_copy; rm "$broken/nrm.png"
expect_refusal "glTF with a missing texture" "model.gltf: material 'Red': nrm.png: cannot open" \
  "$vcmfarm" render "$broken/model.gltf" -n 1 -R 8x8 -o "$tmp/out.exr"
fresh_copy; printf '\x00\x00\xc0\x7f' | dd of="$broken/model.bin" bs=1 seek=48 conv=notrunc status=none
# A NaN normal is repaired from its face (as Blender does), with a note; the render goes on.
"$vcmfarm" render "$broken/model.gltf" --direct -n 1 -R 8x8 -o "$tmp/out.exr" 2>"$tmp/stderr"
check "glTF with a NaN normal renders, its normal repaired" $([ $? -eq 0 ] && [ -s "$tmp/out.exr" ] &&
  grep -qF "model.gltf: note: 2 vertex normals that were zero or not finite were repaired from their faces" "$tmp/stderr"; echo $?)
rm -f "$tmp/out.exr"
# --background replaces any scene's background; continue needs the same one (the hash).
"$vcmfarm" render furnace -n 1 -R 8x8 -q --background 0.2,0.3,0.4 -o "$tmp/bg.exr"
check "render --background" $([ -s "$tmp/bg.exr" ]; echo $?)
expect_refusal "continue without the film's --background" "was it rendered with another --background?" \
  "$vcmfarm" continue "$tmp/bg.exr" -n 1 -o "$tmp/out.exr"
"$vcmfarm" continue "$tmp/bg.exr" -n 1 -q --background 0.2,0.3,0.4
check "continue with the film's --background" $?
expect_refusal "--background of two values" "--background: '1,2': give one value (grey) or three (R,G,B)" \
  "$vcmfarm" render furnace -n 1 -R 8x8 --background 1,2 -o "$tmp/out.exr"
fresh_copy; printf '\x00\x00\x80\x7f' | dd of="$broken/model.bin" bs=1 seek=80 conv=notrunc status=none
expect_refusal "glTF with an infinite uv" "model.gltf: vertex 1 has a non-finite texture coordinate" \
  "$vcmfarm" render "$broken/model.gltf" -n 1 -R 8x8 -o "$tmp/out.exr"
fresh_copy; sed -i 's/"byteOffset": 0, "byteLength": 144/"byteOffset": 100, "byteLength": 144/' "$broken/model.gltf"
expect_refusal "glTF with a buffer view out of range" "cannot read 'model.gltf': GLTF: Buffer view with offset/length (100/144) is out of range" \
  "$vcmfarm" render "$broken/model.gltf" -n 1 -R 8x8 -o "$tmp/out.exr"

fresh_copy; echo "not an image" >"$broken/nrm.png"
expect_refusal "glTF with a texture of an unsupported format" "model.gltf: material 'Red': nrm.png: unsupported texture format" \
  "$vcmfarm" render "$broken/model.gltf" -n 1 -R 8x8 -o "$tmp/out.exr"
fresh_copy; head -c 60 "$import/nrm.png" >"$broken/nrm.png"
expect_refusal "glTF with an unreadable (truncated) texture" "model.gltf: material 'Red': nrm.png: corrupt PNG: file truncated" \
  "$vcmfarm" render "$broken/model.gltf" -n 1 -R 8x8 -o "$tmp/out.exr"
printf '%s' '{"camera":{"position":[0,0,3],"target":[0,0,0],"up":[0,1,0],"fov":40},
  "materials":{"m":{"conductor":[1,1,1],"roughness":-0.1}},
  "shapes":[{"type":"sphere","material":"m","center":[0,0,0],"radius":1}],
  "lights":[{"type":"background","radiance":[1,1,1]}]}' >"$tmp/negative.json"
expect_refusal "negative roughness" "negative.json: materials.m.roughness: must be in [0, 1], found -0.1" \
  "$vcmfarm" render "$tmp/negative.json" -n 1 -R 8x8 -o "$tmp/out.exr"

# Settings lines give numbers in their shortest exact form, and messages count in words.
"$vcmfarm" render furnace -n 1 -R 8x8 -j 1 -v -o "$tmp/words.exr" 2>"$tmp/words.err"
grep -q 'radius_factor=0.003 alpha=0.75 ' "$tmp/words.err"
check "settings line without 17-digit numbers" $?
! grep -qE ';  surfaces;| 1 threads|on 1 workers|JSON scene ,' "$tmp/words.err"
check "no empty fields or wrong plurals in the render's lines" $?
# The header says what a user needs (scene, size, algorithm, what ends the render, the
# output) in one line; the settings text and the renderer's internals (techniques,
# kernels, geometry, skipped work) only with -v.
internals='^settings: |^scene: [0-9]|^geometry: |^rays: |^techniques |^merging tests |^skipped: |^auto: '
"$vcmfarm" render cornell -R 16x16 -n 2 -j 1 -o "$tmp/header.exr" 2>"$tmp/header.err"
head -n 1 "$tmp/header.err" | grep -qxF "vcmfarm render: builtin:cornell, 16x16, vcm, 2 iterations -> $tmp/header.exr" &&
  sed -n 2p "$tmp/header.err" | grep -q '^  iteration 1/2 ' && ! grep -qE "$internals" "$tmp/header.err"
check "render's header: one line, no internals" $?
"$vcmfarm" render cornell-diffuse -R 16x16 -a auto -t 0.2 --target-error 0.5 -k 4 -j 1 -o "$tmp/header.exr" 2>"$tmp/header.err"
head -n 1 "$tmp/header.err" | grep -qxF "vcmfarm render: builtin:cornell-diffuse, 16x16, pt (auto), the first of 0.2 s, estimated RMSE <= 0.5 -> $tmp/header.exr"
check "render's header: what auto chose, the stop conditions" $?
"$vcmfarm" render cornell -R 16x16 -n 2 -j 1 -v -o "$tmp/header.exr" 2>"$tmp/header.err"
for line in '^settings: algorithm=vcm ' '^techniques \(vcm\): ' '^rays: Embree' '^skipped: ' '^geometry: '; do
  grep -qE "$line" "$tmp/header.err" || { echo "  -v lacks $line"; false; }
done
check "render -v: the settings text and the internals" $?
"$vcmfarm" continue "$tmp/header.exr" -n 1 -j 1 2>"$tmp/header.err"
head -n 1 "$tmp/header.err" | grep -qxF "vcmfarm continue: $tmp/header.exr holds 2 iterations of builtin:cornell, 16x16, vcm; rendering 1 iteration -> $tmp/header.exr" &&
  ! grep -qE "$internals" "$tmp/header.err"
check "continue's header: one line, no internals" $?
"$vcmfarm" continue "$tmp/header.exr" -n 1 -j 1 -v 2>"$tmp/header.err"
grep -q '^techniques (vcm): ' "$tmp/header.err" && grep -q '^settings: ' "$tmp/header.err"
check "continue -v: the internals" $?

# Progress where stderr is not a terminal (a log file, Slurm's output): a plain line after
# the first iteration, then one every 10 s, without carriage returns; on a terminal (a
# pseudo-terminal from script(1)), the one line rewritten with carriage returns.
"$vcmfarm" render cornell -R 32x32 -t 11 -j 1 -o "$tmp/progress.exr" 2>"$tmp/progress.err"
grep '^  iteration [0-9]' "$tmp/progress.err" | sed -n 's/.* elapsed \([0-9.]*\) s.*/\1/p' >"$tmp/elapsed"
[ "$(wc -l <"$tmp/elapsed")" -ge 2 ] && ! grep -q $'\r' "$tmp/progress.err" &&
  awk 'NR > 1 && $1 - last < 9.8 {bad = 1} {last = $1} END {exit bad}' "$tmp/elapsed"
check "progress in a log: a line after the first iteration, then every 10 s ($(tr '\n' ' ' <"$tmp/elapsed")s)" $?
"$vcmfarm" continue "$tmp/progress.exr" -t 11 -j 1 -o "$tmp/continued-progress.exr" 2>"$tmp/progress.err"
[ "$(grep -c '^  iteration [0-9]' "$tmp/progress.err")" -ge 2 ] && ! grep -q $'\r' "$tmp/progress.err"
check "progress in a log: continue too" $?
# A root without /dev/pts (a chroot with only proc and sys) has no pseudo-terminal to give:
# the check is then skipped, and said so, not passed.
if script -qec tty /dev/null 2>/dev/null | grep -q '^/dev/'; then
  script -qec "'$vcmfarm' render cornell -R 16x16 -n 30 -j 1 -o '$tmp/tty.exr'" /dev/null >"$tmp/tty.out" 2>&1
  [ "$(grep -o $'\r  iteration [0-9]' "$tmp/tty.out" | wc -l)" -ge 2 ] && [ "$(grep -c '  iteration [0-9]' "$tmp/tty.out")" -eq 1 ]
  check "progress on a terminal: one line, rewritten" $?
else
  skipped=$((skipped + 1))
  echo "skip progress on a terminal: no pseudo-terminal here (script(1) cannot open one)"
fi
"$vcmfarm" render cornell -R 16x16 -n 3 -j 1 -q -o "$tmp/quiet.exr" 2>"$tmp/quiet.err"
[ ! -s "$tmp/quiet.err" ]
check "-q: nothing on stderr" $?
"$vcmfarm" continue "$tmp/ok.exr" -n 1 -q -p "$tmp/continued.png"
check "continue --preview writes the preview" $([ -s "$tmp/continued.png" ]; echo $?)
expect_refusal "continue --preview named .exr" "does not end in .png" "$vcmfarm" continue "$tmp/ok.exr" -n 1 -p "$tmp/p.exr"

# Every command that writes a file says so on one line of stderr, "wrote FILE: what", and
# nothing with -q; counts are in words ("1 iteration", never "1 iterations" or "(s)").
expect_wrote() { # name, expected line (a substring of it), command...
  local name="$1" expected="$2"
  shift 2
  "$@" >"$tmp/stdout" 2>"$tmp/stderr"
  local status=$? ok=0
  [ "$status" -eq 0 ] || { echo "  exit status $status"; ok=1; }
  [ "$(wc -l <"$tmp/stderr")" -eq 1 ] && grep -qF -- "$expected" "$tmp/stderr" ||
    { echo "  stderr is not the one line '$expected':"; sed 's/^/    /' "$tmp/stderr"; ok=1; }
  check "$name" $ok
}
expect_quiet() { # name, command...
  local name="$1"
  shift
  "$@" >"$tmp/stdout" 2>"$tmp/stderr"
  check "$name" "$([ $? -eq 0 ] && [ ! -s "$tmp/stderr" ]; echo $?)"
}
expect_wrote "keygen says what it wrote" "wrote $tmp/said.key: a new farm key" "$vcmfarm" keygen "$tmp/said.key"
expect_quiet "keygen -q" "$vcmfarm" keygen -q "$tmp/quiet.key"
expect_wrote "bake says what it wrote" "wrote $tmp/baked.png: the mean of $tmp/ok.exr (16x16, 3 iterations) as an 8-bit sRGB PNG" \
  "$vcmfarm" bake "$tmp/ok.exr" -o "$tmp/baked.png"
expect_wrote "bake of one iteration" "(8x8, 1 iteration) as a float RGB EXR" "$vcmfarm" bake "$tmp/one.exr" -o "$tmp/baked.exr"
expect_quiet "bake -q" "$vcmfarm" bake -q "$tmp/ok.exr" -o "$tmp/baked.png"
expect_wrote "plot says what it wrote" "wrote $tmp/plot.png: error against time and iterations of 1 film" \
  "$vcmfarm" plot "$tmp/ok.exr" -o "$tmp/plot.png"
expect_quiet "plot -q" "$vcmfarm" plot -q "$tmp/ok.exr" -o "$tmp/plot.png"
"$vcmfarm" render furnace --direct -n 1 -k 2 -R 8x8 -q -o "$tmp/one-more.exr"
expect_wrote "merge says what it wrote, on one line" "wrote $tmp/merged.exr: 2 films merged, 2 iterations [0,1) [2,3)" \
  "$vcmfarm" merge -o "$tmp/merged.exr" "$tmp/one.exr" "$tmp/one-more.exr"
expect_wrote "diff says what it wrote" "wrote $tmp/diff.png: 8x8, clamped at" "$vcmfarm" diff "$tmp/one.exr" "$tmp/one-more.exr" -o "$tmp/diff.png"
expect_quiet "diff -q" "$vcmfarm" diff -q "$tmp/one.exr" "$tmp/one-more.exr" -o "$tmp/diff.png"
"$vcmfarm" errors --window 0,0,1,1 "$tmp/one.exr" "$tmp/one-more.exr" >"$tmp/errors.txt"
check "errors counts one pixel in words" "$(grep -q ': 1 pixel compared, 0 skipped' "$tmp/errors.txt"; echo $?)"
cp "$tmp/one.exr" "$tmp/grown.exr"
"$vcmfarm" continue "$tmp/grown.exr" -n 1 -j 1 2>"$tmp/continue.err"
check "continue counts in words" "$(grep -q "grown.exr holds 1 iteration of" "$tmp/continue.err" &&
  grep -q "^added 1 iteration in" "$tmp/continue.err"; echo $?)"
expect_refusal "submit -o without --wait" "go with --wait" "$vcmfarm" submit furnace -o "$tmp/out.exr" --coordinator ipc://x --secret "$tmp/farm.key"
expect_refusal "submit --wait without -o" "--wait needs -o" "$vcmfarm" submit furnace --wait --coordinator ipc://x --secret "$tmp/farm.key"
# Tags and requirements are checked on the command line, before anything connects, each
# refusal naming the tag and the rule (common/tags.h).
expect_one_line "worker --tags with an empty tag" "vcmfarm worker: --tags: 'night,,gpu' has an empty tag" \
  "$vcmfarm" worker --connect ipc://x --secret "$tmp/farm.key" --tags night,,gpu
expect_one_line "worker --tags with a space" "vcmfarm worker: --tags: tag 'night shift' holds a space" \
  "$vcmfarm" worker --connect ipc://x --secret "$tmp/farm.key" --tags 'night shift'
expect_one_line "worker --tags giving its memory" "--tags: tag 'mem>=64G': mem>= is a requirement a job makes" \
  "$vcmfarm" worker --connect ipc://x --secret "$tmp/farm.key" --tags 'mem>=64G'
expect_one_line "worker --tags too long" "is 33 bytes long, at most 32" \
  "$vcmfarm" worker --connect ipc://x --secret "$tmp/farm.key" --tags "$(printf 'x%.0s' $(seq 33))"
expect_one_line "worker --tags not UTF-8" "vcmfarm worker: --tags: tag 'caf\\xe9' is not UTF-8" \
  "$vcmfarm" worker --connect ipc://x --secret "$tmp/farm.key" --tags "$(printf 'caf\xe9')"
expect_one_line "submit --require a memory without its unit" "--require: requirement 'mem>=64': memory is mem>=N" \
  "$vcmfarm" submit furnace --require 'night,mem>=64' --coordinator ipc://x --secret "$tmp/farm.key"
expect_one_line "submit --require seventeen tags" "--require: more than 16 tags (at 't17')" \
  "$vcmfarm" submit furnace --require t1,t2,t3,t4,t5,t6,t7,t8 --require t9,t10,t11,t12,t13,t14,t15,t16,t17 \
  --coordinator ipc://x --secret "$tmp/farm.key"
expect_one_line "pause without a job" "vcmfarm pause: expected one JOB" "$vcmfarm" pause --coordinator ipc://x --secret "$tmp/farm.key"
expect_one_line "resume of job 0" "vcmfarm resume: JOB: job ids start at 1" "$vcmfarm" resume 0 --coordinator ipc://x --secret "$tmp/farm.key"
expect_refusal "fetch -o named .png" "does not end in .exr" "$vcmfarm" fetch 1 -o "$tmp/f.png" --coordinator ipc://x --secret "$tmp/farm.key"

# submit --wait waits for the job and fetches its film (and a preview); fetch --preview
# too; status speaks of "1 worker" and "1 thread".
"$vcmfarm" coordinator --listen "ipc://$tmp/w.sock" --state "$tmp/state-w" --secret "$tmp/farm.key" --lease-seconds 0.3 \
  2>"$tmp/coordinator-w.log" &
coordinator=$!
"$vcmfarm" worker --connect "ipc://$tmp/w.sock" --secret "$tmp/farm.key" --threads 1 --name single 2>/dev/null &
worker=$!
client=(--coordinator "ipc://$tmp/w.sock" --secret "$tmp/farm.key" --timeout 5)
timeout 120 "$vcmfarm" submit furnace -R 16x16 -n 6 --wait -o "$tmp/waited.exr" -p "$tmp/waited.png" "${client[@]}" \
  >"$tmp/wait.out" 2>"$tmp/wait.err"
check "submit --wait exits 0 when the job is done" $?
check "submit --wait writes the film and the preview" $([ -s "$tmp/waited.exr" ] && [ -s "$tmp/waited.png" ]; echo $?)
"$vcmfarm" info "$tmp/waited.exr" 2>/dev/null | grep -q '\[0,6)'
check "the waited-for film holds the job's iterations" $?
job=$(tail -n 1 "$tmp/wait.out")
expect_wrote "fetch says what it wrote" "wrote $tmp/fetched.exr and $tmp/fetched.png: job $job, 6 iterations [0,6)" \
  "$vcmfarm" fetch "$job" -o "$tmp/fetched.exr" -p "$tmp/fetched.png" "${client[@]}"
check "fetch --preview writes the preview" $([ -s "$tmp/fetched.png" ]; echo $?)
expect_quiet "fetch -q" "$vcmfarm" fetch "$job" -q -o "$tmp/fetched.exr" "${client[@]}"
# A job the coordinator does not have, or one a request does not fit, is bad input: exit
# status 2 (README), as for every other mistake of the command line.
expect_refusal "fetch of an unknown job" "coordinator refused the fetch: no job 999" \
  "$vcmfarm" fetch 999 -o "$tmp/out.exr" "${client[@]}"
expect_refusal "status of an unknown job" "no job 999" "$vcmfarm" status 999 "${client[@]}"
expect_refusal "cancel of an unknown job" "no job 999" "$vcmfarm" cancel 999 "${client[@]}"
expect_refusal "remove of an unknown job" "no job 999" "$vcmfarm" remove 999 "${client[@]}"
expect_refusal "cancel of a job that ended" "vcmfarm cancel: job $job is done already" "$vcmfarm" cancel "$job" "${client[@]}"
expect_refusal "pause of an unknown job" "no job 999" "$vcmfarm" pause 999 "${client[@]}"
expect_refusal "pause of a job that ended" "vcmfarm pause: job $job is done already" "$vcmfarm" pause "$job" "${client[@]}"
expect_refusal "resume of a job that ended" "vcmfarm resume: job $job is done already" "$vcmfarm" resume "$job" "${client[@]}"
expect_refusal "fetch into a missing directory" "-o $tmp/absent/out.exr: no directory $tmp/absent" \
  "$vcmfarm" fetch "$job" -o "$tmp/absent/out.exr" "${client[@]}"
expect_refusal "keygen into a missing directory" "FILE $tmp/absent/k: no directory $tmp/absent" \
  "$vcmfarm" keygen "$tmp/absent/k"
# A scene naming one file: "1 file", on submit and on remove.
mkdir -p "$tmp/one-file"
cp "$scenes/good/meshes/quad.obj" "$tmp/one-file/"
printf '%s' '{"camera":{"position":[0.5,0.5,3],"target":[0.5,0.5,0],"up":[0,1,0],"fov":40},
  "materials":{"m":{"diffuse":[0.5,0.5,0.5]}},
  "shapes":[{"type":"mesh","file":"quad.obj","material":"m"}],
  "lights":[{"type":"background","radiance":[1,1,1]}]}' >"$tmp/one-file/scene.json"
one_file_job=$("$vcmfarm" submit "$tmp/one-file/scene.json" -R 8x8 -n 1 "${client[@]}" 2>"$tmp/submit.err" | tail -n 1)
check "submit counts one file in words" "$(grep -q ': 1 file named by the scene; sent 1 (' "$tmp/submit.err"; echo $?)"
"$vcmfarm" cancel "$one_file_job" "${client[@]}" 2>/dev/null
"$vcmfarm" remove "$one_file_job" "${client[@]}" 2>"$tmp/remove.err"
check "remove counts one file in words" "$(grep -q "removed job $one_file_job and 1 of its 1 file no other job names" "$tmp/remove.err"; echo $?)"
"$vcmfarm" status "${client[@]}" >"$tmp/status.txt"
grep -q '1 thread, ' "$tmp/status.txt" && grep -q 'of 1 worker busy' "$tmp/status.txt" && ! grep -q '1 threads\|1 workers' "$tmp/status.txt"
check "status counts in words" $?
grep -q "submitted: built-in furnace, at most 6 iterations from 0, priority 1" "$tmp/coordinator-w.log"
check "the coordinator's submission line has no empty field" $?
! grep -H '\b1 \(files\|blobs\|jobs\|films\|pixels\|samples\)\b\|(s)' "$tmp"/{wait,submit,remove}.err "$tmp/coordinator-w.log"
check "no '1 files' and no '(s)' in what submit, remove and the coordinator said" $?
kill -TERM "$worker" "$coordinator"
wait "$worker" "$coordinator" 2>/dev/null

echo "$passed passed, $failed failed, $skipped skipped"
[ "$failed" -eq 0 ]
