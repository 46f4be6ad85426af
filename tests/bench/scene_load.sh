#!/usr/bin/env bash
# Load time and peak memory of large scenes (docs/BENCHMARKS.md, "Loading large scenes"):
# the showcase (tests/bench/make_showcase.py, 1.16 M triangles of glTF with textures) and a
# large Mitsuba 3 scene generated here (nothing downloaded): PLY_MESHES binary PLY meshes of
# TRIANGLES_PER_MESH triangles each (tori with normals and texture coordinates, each file its
# own), one OBJ, and SMALL_SHAPES rectangles, cubes and spheres, each with a BSDF of its own
# (diffuse, conductor presets, rough conductors, dielectrics, rough plastics, two-sided),
# three area lights and a constant sky. Each scene is loaded by `vcmfarm render` at 16x16
# for one iteration of path length 1 (load, conversion, BVH and a negligible render), RUNS
# times; prints the median wall time and peak RSS (/usr/bin/time) and the spread.
#
#   bash tests/bench/scene_load.sh BUILD [RUNS]     # default 3 runs; about 3 minutes
#   PLY_MESHES=24 TRIANGLES_PER_MESH=128000 SMALL_SHAPES=1500 bash tests/bench/scene_load.sh build
set -u
build=${1:?usage: scene_load.sh BUILD [RUNS]}
runs=${2:-3}
meshes=${PLY_MESHES:-24}
per_mesh=${TRIANGLES_PER_MESH:-128000}
small=${SMALL_SHAPES:-1500}
vcmfarm=$(cd "$build" && pwd)/vcmfarm
here=$(cd "$(dirname "$0")" && pwd)
tmp=$(mktemp -d /tmp/scene_load.XXXXXX)
trap 'rm -rf "$tmp"' EXIT

python3 "$here/make_showcase.py" "$tmp/showcase" >/dev/null || exit 1

mkdir -p "$tmp/large/meshes"
python3 - "$tmp/large" "$meshes" "$per_mesh" "$small" <<'EOF' || exit 1
import array, math, struct, sys
out, meshes, per_mesh, small = sys.argv[1], int(sys.argv[2]), int(sys.argv[3]), int(sys.argv[4])
# A torus of nu x nv quads: nu = 4 nv, 2 nu nv >= per_mesh triangles.
nv = max(3, int(math.ceil(math.sqrt(per_mesh / 8.0))))
nu = 4 * nv
faces = bytearray()
for i in range(nu):
    for j in range(nv):
        a, b = i * nv + j, ((i + 1) % nu) * nv + j
        c, d = ((i + 1) % nu) * nv + (j + 1) % nv, i * nv + (j + 1) % nv
        faces += struct.pack("<B3iB3i", 3, a, b, c, 3, a, c, d)
header = ("ply\nformat binary_little_endian 1.0\nelement vertex %d\n"
          "property float x\nproperty float y\nproperty float z\n"
          "property float nx\nproperty float ny\nproperty float nz\n"
          "property float u\nproperty float v\n"
          "element face %d\nproperty list uchar int vertex_indices\nend_header\n" % (nu * nv, 2 * nu * nv)).encode()
triangles = 0
for m in range(meshes):
    big, tube = 1.0 + 0.05 * (m % 5), 0.25 + 0.02 * (m % 7)
    v = array.array("f")
    for i in range(nu):
        u = 2 * math.pi * i / nu
        for j in range(nv):
            w = 2 * math.pi * j / nv
            r = tube * (1 + 0.05 * math.sin(7 * u + 3 * w + m))
            n = (math.cos(w) * math.cos(u), math.cos(w) * math.sin(u), math.sin(w))
            v.extend(((big + r * math.cos(w)) * math.cos(u), (big + r * math.cos(w)) * math.sin(u), r * math.sin(w)))
            v.extend(n)
            v.extend((i / nu, j / nv))
    with open("%s/meshes/torus%02d.ply" % (out, m), "wb") as f:
        f.write(header)
        f.write(v.tobytes())
        f.write(faces)
    triangles += 2 * nu * nv
# One OBJ of a 200 x 200 grid (80,000 triangles), through Assimp's OBJ reader.
with open(out + "/meshes/ground.obj", "w") as f:
    g = 200
    for y in range(g + 1):
        for x in range(g + 1):
            f.write("v %g %g %g\n" % (40.0 * x / g - 20, 0.2 * math.sin(x * 0.3) * math.cos(y * 0.2), 40.0 * y / g - 20))
    for y in range(g):
        for x in range(g):
            a = y * (g + 1) + x + 1
            f.write("f %d %d %d\nf %d %d %d\n" % (a, a + g + 1, a + 1, a + 1, a + g + 1, a + g + 2))
triangles += 2 * 200 * 200
kinds = ['<bsdf type="diffuse" id="m%d"><rgb name="reflectance" value="%g, %g, %g"/></bsdf>',
         '<bsdf type="conductor" id="m%d"><string name="material" value="%s"/></bsdf>',
         '<bsdf type="roughconductor" id="m%d"><string name="material" value="%s"/><float name="alpha" value="%g"/>'
         '<string name="distribution" value="ggx"/></bsdf>',
         '<bsdf type="dielectric" id="m%d"><float name="int_ior" value="%g"/></bsdf>',
         '<bsdf type="roughplastic" id="m%d"><rgb name="diffuse_reflectance" value="%g, %g, %g"/>'
         '<float name="alpha" value="%g"/><string name="distribution" value="ggx"/></bsdf>',
         '<bsdf type="twosided" id="m%d"><bsdf type="diffuse"><rgb name="reflectance" value="%g, %g, %g"/></bsdf></bsdf>']
metals = ["Au", "Cu", "Al", "Ag", "Cr"]
def bsdf(i):
    k = i % len(kinds)
    c = (0.2 + 0.6 * ((i * 7) % 11) / 10, 0.2 + 0.6 * ((i * 3) % 7) / 6, 0.2 + 0.6 * ((i * 5) % 13) / 12)
    if k in (0, 5): return kinds[k] % ((i,) + c)
    if k == 1: return kinds[k] % (i, metals[i % 5])
    if k == 2: return kinds[k] % (i, metals[i % 5], 0.05 + 0.01 * (i % 30))
    if k == 3: return kinds[k] % (i, 1.3 + 0.01 * (i % 40))
    return kinds[k] % ((i,) + c + (0.05 + 0.01 * (i % 30),))
with open(out + "/scene.xml", "w") as f:
    f.write('<?xml version="1.0"?>\n<scene version="3.0.0">\n<default name="spp" value="64"/>\n'
            '<integrator type="path"><integer name="max_depth" value="8"/></integrator>\n'
            '<sensor type="perspective"><float name="fov" value="50"/><transform name="to_world">'
            '<lookat origin="0, 14, 30" target="0, 0, 0" up="0, 1, 0"/></transform>'
            '<sampler type="independent"><integer name="sample_count" value="$spp"/></sampler>'
            '<film type="hdrfilm"><integer name="width" value="1920"/><integer name="height" value="1080"/></film></sensor>\n')
    for i in range(small + meshes):
        f.write(bsdf(i) + "\n")
    f.write('<shape type="obj"><string name="filename" value="meshes/ground.obj"/><ref id="m0"/></shape>\n')
    for m in range(meshes):
        x, z = -15 + 30.0 * (m % 6) / 5, -12 + 24.0 * (m // 6) / max(1, (meshes - 1) // 6)
        f.write('<shape type="ply"><string name="filename" value="meshes/torus%02d.ply"/><transform name="to_world">'
                '<rotate x="1" angle="90"/><scale value="0.8"/><translate x="%g" y="1" z="%g"/></transform>'
                '<ref id="m%d"/></shape>\n' % (m, x, z, small + m))
    for i in range(small):
        t = ["rectangle", "cube", "sphere"][i % 3]
        x, z = -18 + 36.0 * ((i * 37) % 101) / 100, -18 + 36.0 * ((i * 53) % 97) / 96
        if t == "sphere":
            f.write('<shape type="sphere"><point name="center" x="%g" y="%g" z="%g"/><float name="radius" value="0.15"/>'
                    '<ref id="m%d"/></shape>\n' % (x, 0.3 + (i % 7) * 0.2, z, i))
        else:
            f.write('<shape type="%s"><transform name="to_world"><scale value="0.15"/><rotate y="1" angle="%d"/>'
                    '<translate x="%g" y="%g" z="%g"/></transform><ref id="m%d"/></shape>\n'
                    % (t, (i * 17) % 360, x, 0.3 + (i % 5) * 0.25, z, i))
    for k in range(3):
        f.write('<shape type="rectangle"><transform name="to_world"><scale value="2"/><rotate x="1" angle="90"/>'
                '<translate x="%d" y="12" z="0"/></transform><emitter type="area"><rgb name="radiance" value="8"/>'
                '</emitter></shape>\n' % (-10 + 10 * k))
    f.write('<emitter type="constant"><rgb name="radiance" value="0.2"/></emitter>\n</scene>\n')
print("large Mitsuba scene: %d triangles in %d PLY files and one OBJ, %d small shapes, %d BSDFs"
      % (triangles, meshes, small, small + meshes), file=sys.stderr)
EOF
du -sh "$tmp/showcase" "$tmp/large" | sed 's/^/# /'

measure() { # name scene: RUNS loads, median wall time and peak RSS
  local name=$1 scene=$2 times=() mems=()
  for r in $(seq 1 "$runs"); do
    /usr/bin/time -f "%e %M" -o "$tmp/time" "$vcmfarm" render "$scene" -R 16x16 -n 1 -l 1 -q -o "$tmp/x.exr" \
      2>"$tmp/stderr" >/dev/null || { cat "$tmp/stderr" >&2; exit 1; }
    read -r t m <"$tmp/time"
    times+=("$t")
    mems+=("$m")
  done
  local tm mm
  tm=$(printf '%s\n' "${times[@]}" | sort -g | awk '{a[NR] = $1} END {print a[int((NR + 1) / 2)]}')
  mm=$(printf '%s\n' "${mems[@]}" | sort -g | awk '{a[NR] = $1} END {printf "%.0f", a[int((NR + 1) / 2)] / 1024}')
  echo "| $name | $tm s (runs: ${times[*]}) | $mm MiB | $(grep -c 'note:' "$tmp/stderr") |"
}

echo "# $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ //'), family $(grep -m1 'cpu family' /proc/cpuinfo | cut -d: -f2 | tr -d ' ') model $(grep -m1 '^model\s' /proc/cpuinfo | cut -d: -f2 | tr -d ' '), $(nproc) cores; $(date -u +%F); build $(git -C "$here" rev-parse --short HEAD)"
echo "| scene | load (median of $runs) | peak RSS (median) | notes at load |"
echo "|---|---|---|---|"
measure "showcase.gltf (1,157,048 triangles)" "$tmp/showcase/showcase.gltf"
measure "large Mitsuba scene.xml" "$tmp/large/scene.xml"
