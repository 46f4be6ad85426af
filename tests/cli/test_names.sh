#!/usr/bin/env bash
# Issue 41: names and paths that end up in a film or in JSON are UTF-8 and fit, or are
# refused with a clear error before anything is written. A scene path that is not UTF-8,
# or longer than a film's 511 bytes (where it used to be cut, mid-character), made a film
# that `render` wrote with exit status 0 and no tool could read; a job name that is not
# UTF-8 made `status --json` invalid for the whole farm.
#
#   test_names.sh VCMFARM
set -u
vcmfarm="$1"
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
passed=0
failed=0
check() { # name, condition result (0 = pass)
  if [ "$2" -eq 0 ]; then passed=$((passed + 1)); echo "ok   $1"; else failed=$((failed + 1)); echo "FAIL $1"; fi
}
refused() { # name, expected substring, command...: exit 2 with that message
  local name="$1" expected="$2" status
  shift 2
  "$@" >"$tmp/stdout" 2>"$tmp/stderr"
  status=$?
  [ "$status" -eq 2 ] && grep -qF -- "$expected" "$tmp/stderr"
  local ok=$?
  [ "$ok" -eq 0 ] || { echo "  exit $status; stderr:"; sed 's/^/    /' "$tmp/stderr"; }
  check "$name" "$ok"
}
scene='{"camera": {"position": [0, 1, 3], "target": [0, 0, 0], "fov": 40, "resolution": [8, 8]},
 "materials": {"white": {"diffuse": [0.7, 0.7, 0.7]}, "lamp": {}},
 "shapes": [{"type": "sphere", "center": [0, 0, 0], "radius": 1, "material": "white"},
            {"type": "sphere", "center": [0, 3, 1], "radius": 0.3, "material": "lamp", "emission": [20, 18, 15]}]}'

# A scene file whose name is Latin-1 ("café" with byte 0xE9), not UTF-8.
latin1="$tmp/caf"$'\xe9'".json"
printf '%s\n' "$scene" >"$latin1"
refused "render of a scene whose path is not UTF-8" "is not valid UTF-8" \
  "$vcmfarm" render "$latin1" -n 1 -q -o "$tmp/latin1.exr"
[ ! -e "$tmp/latin1.exr" ]
check "nothing written for it" $?

# A path of more than 511 bytes of two-byte characters: cut at 511 it would end mid-character.
deep="$tmp"
for _ in 1 2 3; do
  deep="$deep/$(printf 'é%.0s' $(seq 100))"
done
mkdir -p "$deep" && printf '%s\n' "$scene" >"$deep/scene.json"
refused "render of a scene whose path is longer than a film holds" "a film holds at most 511" \
  "$vcmfarm" render "$deep/scene.json" -n 1 -q -o "$tmp/deep.exr"
[ ! -e "$tmp/deep.exr" ]
check "nothing written for it" $?

# The same scenes under fitting names render, and their films read.
cp "$latin1" "$tmp/cafe.json"
"$vcmfarm" render "$tmp/cafe.json" -n 1 -q -o "$tmp/cafe.exr" && "$vcmfarm" info "$tmp/cafe.exr" >/dev/null
check "a UTF-8 scene path renders and reads" $?

# submit refuses them before it sends anything (no coordinator needed to find out).
"$vcmfarm" keygen "$tmp/farm.key" >/dev/null 2>&1 || "$vcmfarm" keygen -o "$tmp/farm.key" >/dev/null 2>&1
chmod 600 "$tmp/farm.key"
refused "submit with a job name that is not UTF-8" "not valid UTF-8" \
  "$vcmfarm" submit furnace --name "caf"$'\xe9' --coordinator ipc://"$tmp/none" --secret "$tmp/farm.key"
refused "submit of a scene whose path is not UTF-8" "not valid UTF-8" \
  "$vcmfarm" submit "$latin1" --coordinator ipc://"$tmp/none" --secret "$tmp/farm.key"
refused "submit of a scene whose path is too long" "a film holds at most 511" \
  "$vcmfarm" submit "$deep/scene.json" --name deep --coordinator ipc://"$tmp/none" --secret "$tmp/farm.key"

echo "$passed passed, $failed failed"
[ "$failed" -eq 0 ]
