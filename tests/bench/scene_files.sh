#!/usr/bin/env bash
# Scene files by content hash (docs/BENCHMARKS.md, "Scene files by content hash"): one
# coordinator and one worker over ipc://, a JSON scene naming a binary PLY of the knot's
# size (115,200 triangles), then a second scene naming it and a 4096 x 2048 EXR
# environment map, then the first scene again as another job, then a scene naming a
# 256 MiB OBJ (sent and fetched in 16 chunks). Prints submit's wall time
# and peak memory, and the worker's fetch time of each file (from its log).
#
#   bash tests/bench/scene_files.sh BUILD_DIR
set -u
build="$1"
vcmfarm="$build/vcmfarm"
source "$(dirname "${BASH_SOURCE[0]}")/farm_lib.sh"
CLIENT_TIMEOUT=20
farm_setup files
fail() { echo "scene_files.sh: $*" >&2; tail -n 20 "$tmp"/*.log >&2; exit 1; }

# A (3,7) torus-knot tube of 960 x 60 quads: 57,600 vertices, 115,200 triangles.
python3 - "$tmp/knot.ply" <<'EOF' || exit 1
import math, struct, sys
nu, nv, tube = 960, 60, 0.08
def knot(t):
    return ((1 + 0.4 * math.cos(7 * t)) * math.cos(3 * t), (1 + 0.4 * math.cos(7 * t)) * math.sin(3 * t),
            0.4 * math.sin(7 * t))
verts = []
for i in range(nu):
    t = 2 * math.pi * i / nu
    c, d = knot(t), knot(t + 1e-4)
    tg = [d[k] - c[k] for k in range(3)]
    l = math.sqrt(sum(a * a for a in tg)); tg = [a / l for a in tg]
    n = [tg[1], -tg[0], 0.0]
    l = math.sqrt(sum(a * a for a in n)); n = [a / l for a in n]
    b = [tg[1] * n[2] - tg[2] * n[1], tg[2] * n[0] - tg[0] * n[2], tg[0] * n[1] - tg[1] * n[0]]
    for j in range(nv):
        a = 2 * math.pi * j / nv
        verts.append([c[k] + tube * (math.cos(a) * n[k] + math.sin(a) * b[k]) for k in range(3)])
with open(sys.argv[1], "wb") as f:
    f.write(("ply\nformat binary_little_endian 1.0\nelement vertex %d\nproperty float x\nproperty float y\n"
             "property float z\nelement face %d\nproperty list uchar int vertex_indices\nend_header\n"
             % (len(verts), 2 * nu * nv)).encode())
    for v in verts:
        f.write(struct.pack("<3f", *v))
    for i in range(nu):
        for j in range(nv):
            a, b = i * nv + j, ((i + 1) % nu) * nv + j
            c, d = ((i + 1) % nu) * nv + (j + 1) % nv, i * nv + (j + 1) % nv
            f.write(struct.pack("<B3i", 3, a, b, c) + struct.pack("<B3i", 3, a, c, d))
EOF
# A 4096 x 2048 map: one path-traced iteration of cornell-env, baked to RGB.
"$vcmfarm" render cornell-env --direct -a pt -n 1 -R 4096x2048 -q -o "$tmp/map-film.exr" || exit 1
"$vcmfarm" bake "$tmp/map-film.exr" -o "$tmp/sky.exr" >/dev/null || exit 1
# A 256 MiB OBJ: one quad and comment lines, to time a file of 16 chunks (16 MiB each).
{ printf 'v -1 -1 0\nv 1 -1 0\nv 1 1 0\nv -1 1 0\nf 1 2 3 4\n'
  yes "# padding: a comment line the OBJ reader skips, to make the file big" | head -c 256M
} >"$tmp/big.obj"
camera='"camera": {"position": [0, -4, 1.5], "target": [0, 0, 0], "up": [0, 0, 1], "fov": 45, "resolution": [64, 64]}'
shapes='"shapes": [{"type": "mesh", "file": "knot.ply", "material": "grey"}]'
echo "{$camera, \"materials\": {\"grey\": {\"diffuse\": [0.6, 0.6, 0.6]}}, $shapes,
  \"lights\": [{\"type\": \"background\", \"radiance\": [1, 1, 1]}]}" >"$tmp/knot.json"
echo "{$camera, \"materials\": {\"grey\": {\"diffuse\": [0.6, 0.6, 0.6]}}, $shapes,
  \"lights\": [{\"type\": \"environment\", \"file\": \"sky.exr\"}]}" >"$tmp/knot-map.json"
echo "{$camera, \"materials\": {\"grey\": {\"diffuse\": [0.6, 0.6, 0.6]}},
  \"shapes\": [{\"type\": \"mesh\", \"file\": \"big.obj\", \"material\": \"grey\"}],
  \"lights\": [{\"type\": \"background\", \"radiance\": [1, 1, 1]}]}" >"$tmp/big.json"

"$vcmfarm" coordinator --listen "$url" --state "$tmp/state" --secret "$tmp/key" >"$tmp/coordinator.log" 2>&1 &
pids+=($!)
"$vcmfarm" worker --connect "$url" --secret "$tmp/key" --threads 1 --name bench --cache "$tmp/cache" \
  >"$tmp/worker.log" 2>&1 &
pids+=($!)

echo "| scene | submit: wall, peak RSS | worker's fetches |"
echo "|---|---|---|"
for scene in knot knot-map knot big; do
  fetched_before=$(grep -c "fetched blob" "$tmp/worker.log")
  /usr/bin/time -f "%e %M" -o "$tmp/time" "$vcmfarm" submit "$tmp/$scene.json" -n 2 --coordinator "$url" \
    --secret "$tmp/key" --timeout 60 >"$tmp/job" 2>"$tmp/submit.log" || fail "submit $scene"
  job=$(tail -n 1 "$tmp/job")
  deadline=$((SECONDS + 300))
  until client status "$job" --json 2>/dev/null | tr -d ' \t\n' | grep -q '"state":"done"'; do
    [ "$SECONDS" -lt "$deadline" ] || fail "job $job not done in time"
    sleep 0.2
  done
  read -r wall rss <"$tmp/time"
  fetches=$(grep "fetched blob" "$tmp/worker.log" | tail -n +$((fetched_before + 1)) |
    sed -n "s/.*(file '\([^']*\)', \([0-9]*\) bytes) in \([0-9.]*\) s.*/\1 (\2 bytes): \3 s/p" | paste -sd ';' -)
  printf "| %s | %.2f s, %d MB | %s |\n" "$scene" "$wall" "$((rss / 1024))" "${fetches:-nothing fetched}"
done
