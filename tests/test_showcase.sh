#!/usr/bin/env bash
# The showcase scene's generator (tests/bench/make_showcase.py, docs/SCENES.md "The
# showcase scene") at a small size: its output is valid glTF 2.0 by the script's own check,
# the same budget gives the same bytes, the check refuses damaged files, and vcmfarm loads
# the glTF file and its JSON wrapper without a note (nothing in the file is dropped) and
# renders them finitely; the same of the benchmark room's generator (make_room.py).
#
#   test_showcase.sh VCMFARM SOURCE_DIR
set -u
vcmfarm="$1"
bench="$2/tests/bench"
command -v python3 >/dev/null || { echo "python3 not found: skipped"; exit 77; }
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
passed=0
failed=0
check() { # name, condition result (0 = pass)
  if [ "$2" -eq 0 ]; then passed=$((passed + 1)); echo "ok   $1"; else failed=$((failed + 1)); echo "FAIL $1"; fi
}

python3 "$bench/make_showcase.py" "$tmp/a" --triangles 20000 --check >"$tmp/out" 2>&1
status=$?
cat "$tmp/out"
check "generates_and_checks" "$status"
triangles=$(sed -n 's/.*valid; \([0-9]*\) triangles in its meshes.*/\1/p' "$tmp/out")
[ -n "$triangles" ] && [ "$triangles" -ge 20000 ]
check "at_least_the_budget ($triangles triangles)" $?
for f in showcase.gltf showcase.bin showcase.json paving_normal.png leaf_basecolor.png; do
  [ -s "$tmp/a/$f" ] || { echo "  missing $f"; false; }
done
check "writes_every_file" $?

python3 "$bench/make_showcase.py" "$tmp/b" --triangles 20000 >/dev/null 2>&1 && diff -r "$tmp/a" "$tmp/b" >/dev/null
check "deterministic" $?

# Damaged copies: a POSITION bound that is not the data's, an index beyond the vertices, a
# buffer longer than its file. Each must be refused naming the problem.
damage() { # name, expected message, python statement on the parsed glTF g
  local name="$1" expected="$2"
  rm -rf "$tmp/bad" && cp -r "$tmp/a" "$tmp/bad"
  python3 - "$tmp/bad/showcase.gltf" "$3" <<'EOF'
import json, sys
g = json.load(open(sys.argv[1]))
exec(sys.argv[2])
json.dump(g, open(sys.argv[1], "w"))
EOF
  python3 "$bench/gltf_check.py" "$tmp/bad/showcase.gltf" >"$tmp/stdout" 2>"$tmp/stderr"
  local status=$?
  [ "$status" -eq 1 ] && grep -qF -- "$expected" "$tmp/stderr"
  local ok=$?
  [ "$ok" -eq 0 ] || { echo "  exit $status; stderr:"; sed 's/^/    /' "$tmp/stderr"; }
  check "refuses_$name" "$ok"
}
damage position_bounds "POSITION bounds" 'g["accessors"][g["meshes"][0]["primitives"][0]["attributes"]["POSITION"]]["max"][0] += 1'
damage index_range "out of range" 'p = g["meshes"][0]["primitives"][0]; g["accessors"][p["attributes"]["POSITION"]]["count"] -= 1; [g["accessors"][p["attributes"][k]].__setitem__("count", g["accessors"][p["attributes"][k]]["count"] - 1) for k in p["attributes"] if k != "POSITION"]'
damage buffer_length "byteLength" 'g["buffers"][0]["byteLength"] += 4'
damage extensions_used "extensionsUsed" 'g["extensionsUsed"].remove("KHR_materials_ior")'

# vcmfarm reads every feature: a load note naming the file would be something dropped (the
# light units the file is read in, printed because it has lamps and emitters, drop nothing).
# renders NAME FILE GLTF LIGHTS RENDER_ARGS...: FILE renders with RENDER_ARGS, exit 0,
# without a note but GLTF's light units, with no non-finite sample, and its description
# lists LIGHTS.
renders() {
  local name="$1" file="$2" stem="$3" lights="$4"
  shift 4
  "$vcmfarm" render "$file" -v "$@" >"$tmp/render.out" 2>&1
  local status=$?
  ! grep ": note:" "$tmp/render.out" | grep -vq ": note: \($stem: \)\?light units: punctual lights in W/sr = candela / 683" &&
    grep -q " 0 non-finite sample" "$tmp/render.out" && grep -q "$lights" "$tmp/render.out"
  local ok=$?
  [ "$status" -eq 0 ] && [ "$ok" -eq 0 ]
  ok=$?
  [ "$ok" -eq 0 ] || sed 's/^/    /' "$tmp/render.out"
  check "$name" "$ok"
}
for scene in showcase.gltf showcase.json; do
  renders "renders_$scene" "$tmp/a/$scene" showcase.gltf "1 spot, 1 directional" -R 96x54 -n 2 -o "$tmp/$scene.exr"
done

# The benchmark room (tests/bench/make_room.py): valid, deterministic, and read whole (its
# point and spot lights, the transmission, ior and metallic lobes) and rendered finitely by
# the unbiased and the merging algorithms.
python3 "$bench/make_room.py" "$tmp/room" --check >"$tmp/out" 2>&1
status=$?
[ "$status" -eq 0 ] || cat "$tmp/out"
check "room_generates_and_checks" "$status"
python3 "$bench/make_room.py" "$tmp/room2" >/dev/null 2>&1 && diff -r "$tmp/room" "$tmp/room2" >/dev/null
check "room_deterministic" $?
for algorithm in pt vcm; do
  renders "room_renders_with_$algorithm" "$tmp/room/room.gltf" room.gltf "1 point, 1 spot" -a "$algorithm" -R 64x36 -n 2 \
    -o "$tmp/room-$algorithm.exr"
done

echo "$passed passed, $failed failed"
[ "$failed" -eq 0 ]
