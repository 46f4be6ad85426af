#!/usr/bin/env python3
"""A structural check of a glTF 2.0 file with external buffers and PNG images, Python's
standard library only: what make_showcase.py --check runs, and usable alone.

usage: gltf_check.py FILE.gltf

Verifies: buffer byteLength against the file, bufferViews inside their buffer, accessors'
alignment and count * stride inside their bufferView, POSITION min/max equal to the
data's bounds, indices unsigned and in range, attribute counts equal, NORMAL and TANGENT
of unit length (TANGENT w = +-1), TEXCOORD_0 finite, material, texture, image, mesh,
camera and light references, unit rotations, a node tree without cycles or shared
children, spot cone angles, extensionsUsed listing every extension used, and every image
a PNG whose chunks' CRCs hold and whose data inflates to its size. Prints the triangle
count in the meshes and in the scene (instances counted each time); exits 1 with the
problems listed when there are any.
"""
import json
import math
import os
import struct
import sys
import zlib

# ---- the checks ----------------------------------------------------------------------------------

COMPONENT_SIZE = {5120: 1, 5121: 1, 5122: 2, 5123: 2, 5125: 4, 5126: 4}
COMPONENT_CODE = {5120: "b", 5121: "B", 5122: "h", 5123: "H", 5125: "I", 5126: "f"}
TYPE_WIDTH = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4, "MAT2": 4, "MAT3": 9, "MAT4": 16}


class Problems(list):
    def add(self, where, what):
        self.append("%s: %s" % (where, what))


def check_png(path, problems, where):
    try:
        with open(path, "rb") as f:
            data = f.read()
    except OSError as e:
        problems.add(where, "cannot read %s: %s" % (path, e))
        return
    if data[:8] != b"\x89PNG\r\n\x1a\n":
        problems.add(where, "%s is not a PNG" % path)
        return
    pos, idat, header = 8, bytearray(), None
    while pos + 8 <= len(data):
        length, kind = struct.unpack(">I4s", data[pos:pos + 8])
        body = data[pos + 8:pos + 8 + length]
        crc = data[pos + 8 + length:pos + 12 + length]
        if len(body) != length or len(crc) != 4 or \
                struct.unpack(">I", crc)[0] != zlib.crc32(kind + body) & 0xFFFFFFFF:
            problems.add(where, "%s: chunk %r is cut or has a wrong CRC" % (path, kind))
            return
        if kind == b"IHDR":
            header = struct.unpack(">IIBBBBB", body)
        elif kind == b"IDAT":
            idat.extend(body)
        elif kind == b"IEND":
            break
        pos += 12 + length
    if header is None:
        problems.add(where, "%s has no IHDR" % path)
        return
    width, height, depth, colour_type = header[:4]
    channels = {0: 1, 2: 3, 4: 2, 6: 4}.get(colour_type)
    if depth != 8 or channels is None:
        problems.add(where, "%s: only 8-bit grey/RGB(A) expected" % path)
        return
    try:
        raw = zlib.decompress(bytes(idat))
    except zlib.error as e:
        problems.add(where, "%s: image data does not inflate: %s" % (path, e))
        return
    if len(raw) != height * (1 + width * channels):
        problems.add(where, "%s: %d bytes of image data, expected %d" % (path, len(raw), height * (1 + width * channels)))


def check_gltf(path):
    """Problems of the glTF 2.0 file at `path` (an empty list: none) and its triangle
    counts (in the meshes; in the scene, instances counted each time)."""
    problems = Problems()
    base = os.path.dirname(path)
    with open(path) as f:
        g = json.load(f)
    if g.get("asset", {}).get("version") != "2.0":
        problems.add("asset.version", "not 2.0")
    buffers = []
    for i, buf in enumerate(g.get("buffers", [])):
        try:
            with open(os.path.join(base, buf["uri"]), "rb") as f:
                data = f.read()
        except (OSError, KeyError) as e:
            problems.add("buffers[%d]" % i, "cannot read: %s" % e)
            data = b""
        if len(data) != buf.get("byteLength"):
            problems.add("buffers[%d]" % i, "byteLength %s but the file has %d bytes" % (buf.get("byteLength"), len(data)))
        buffers.append(data)
    views = g.get("bufferViews", [])
    for i, v in enumerate(views):
        end = v.get("byteOffset", 0) + v["byteLength"]
        if v["buffer"] >= len(buffers) or end > len(buffers[v["buffer"]]):
            problems.add("bufferViews[%d]" % i, "ends at %d, beyond its buffer" % end)
        stride = v.get("byteStride")
        if stride is not None and (stride < 4 or stride > 252 or stride % 4):
            problems.add("bufferViews[%d]" % i, "byteStride %d" % stride)
    accessors = g.get("accessors", [])

    def read(index, where):
        """The accessor's values as a flat list, or None after noting why not."""
        a = accessors[index] if 0 <= index < len(accessors) else None
        if a is None:
            problems.add(where, "accessor %d does not exist" % index)
            return None
        if a.get("componentType") not in COMPONENT_SIZE or a.get("type") not in TYPE_WIDTH:
            problems.add("accessors[%d]" % index, "bad componentType or type")
            return None
        size, width = COMPONENT_SIZE[a["componentType"]], TYPE_WIDTH[a["type"]]
        view = views[a["bufferView"]]
        element = size * width
        stride = view.get("byteStride", element)
        offset = view.get("byteOffset", 0) + a.get("byteOffset", 0)
        count = a["count"]
        if offset % size:
            problems.add("accessors[%d]" % index, "offset %d not aligned to its component size" % offset)
        if count < 1 or a.get("byteOffset", 0) + stride * (count - 1) + element > view["byteLength"]:
            problems.add("accessors[%d]" % index, "%d elements of %d bytes do not fit their bufferView of %d bytes"
                         % (count, element, view["byteLength"]))
            return None
        data = buffers[view["buffer"]]
        code = "<" + COMPONENT_CODE[a["componentType"]] * width
        if stride == element:
            values = list(struct.unpack("<%d%s" % (count * width, COMPONENT_CODE[a["componentType"]]),
                                        data[offset:offset + count * element]))
        else:
            values = []
            for k in range(count):
                values.extend(struct.unpack_from(code, data, offset + k * stride))
        return values

    def finite(values):
        return all(math.isfinite(v) for v in values)

    unique = 0
    mesh_triangles = []
    for mi, mesh in enumerate(g.get("meshes", [])):
        tris = 0
        for pi, prim in enumerate(mesh["primitives"]):
            where = "meshes[%d] '%s' primitives[%d]" % (mi, mesh.get("name", ""), pi)
            attrs = prim["attributes"]
            if prim.get("mode", 4) != 4:
                problems.add(where, "not triangles")
            if "POSITION" not in attrs:
                problems.add(where, "no POSITION")
                continue
            pos = read(attrs["POSITION"], where + ".POSITION")
            if pos is None:
                continue
            count = len(pos) // 3
            a = accessors[attrs["POSITION"]]
            if not finite(pos):
                problems.add(where, "non-finite POSITION")
            elif "min" not in a or "max" not in a:
                problems.add(where, "POSITION without min and max")
            else:
                for k in range(3):
                    lo, hi = min(pos[k::3]), max(pos[k::3])
                    if lo != a["min"][k] or hi != a["max"][k]:
                        problems.add(where, "POSITION bounds [%r, %r] on axis %d, min/max say [%r, %r]"
                                     % (lo, hi, k, a["min"][k], a["max"][k]))
            for name, values_width in (("NORMAL", 3), ("TANGENT", 4), ("TEXCOORD_0", 2)):
                if name not in attrs:
                    continue
                vals = read(attrs[name], where + "." + name)
                if vals is None:
                    continue
                if len(vals) // values_width != count:
                    problems.add(where, "%s has %d elements, POSITION %d" % (name, len(vals) // values_width, count))
                if not finite(vals):
                    problems.add(where, "non-finite %s" % name)
                    continue
                if name in ("NORMAL", "TANGENT"):
                    for k in range(0, len(vals), values_width):
                        length = math.sqrt(vals[k] ** 2 + vals[k + 1] ** 2 + vals[k + 2] ** 2)
                        if abs(length - 1.0) > 1e-3:
                            problems.add(where, "%s %d has length %g" % (name, k // values_width, length))
                            break
                        if name == "TANGENT" and vals[k + 3] not in (1.0, -1.0):
                            problems.add(where, "TANGENT %d has w %g" % (k // 4, vals[k + 3]))
                            break
            if "indices" in prim:
                ia = accessors[prim["indices"]]
                if ia.get("componentType") not in (5121, 5123, 5125) or ia.get("type") != "SCALAR":
                    problems.add(where, "indices are not unsigned scalars")
                idx = read(prim["indices"], where + ".indices")
                if idx is None:
                    continue
                if len(idx) % 3:
                    problems.add(where, "%d indices, not a multiple of 3" % len(idx))
                if idx and (min(idx) < 0 or max(idx) >= count):
                    problems.add(where, "index %d out of range (%d vertices)" % (max(idx), count))
                tris += len(idx) // 3
            else:
                tris += count // 3
            material = prim.get("material")
            if material is not None and not 0 <= material < len(g.get("materials", [])):
                problems.add(where, "material %d does not exist" % material)
        mesh_triangles.append(tris)
        unique += tris

    textures = g.get("textures", [])
    for i, t in enumerate(textures):
        if not 0 <= t.get("source", -1) < len(g.get("images", [])):
            problems.add("textures[%d]" % i, "no image")
    for i, image in enumerate(g.get("images", [])):
        check_png(os.path.join(base, image["uri"]), problems, "images[%d]" % i)
    used_extensions = set()
    for i, m in enumerate(g.get("materials", [])):
        used_extensions.update(m.get("extensions", {}).keys())
        refs = [m.get("normalTexture"), m.get("emissiveTexture"), m.get("occlusionTexture")]
        pbr_block = m.get("pbrMetallicRoughness", {})
        refs += [pbr_block.get("baseColorTexture"), pbr_block.get("metallicRoughnessTexture")]
        for r in refs:
            if r is not None and not 0 <= r["index"] < len(textures):
                problems.add("materials[%d]" % i, "texture %d does not exist" % r["index"])
        if m.get("alphaMode", "OPAQUE") not in ("OPAQUE", "MASK", "BLEND"):
            problems.add("materials[%d]" % i, "alphaMode %s" % m["alphaMode"])
    used_extensions.update(g.get("extensions", {}).keys())

    nodes = g.get("nodes", [])
    parents = [None] * len(nodes)
    lights = g.get("extensions", {}).get("KHR_lights_punctual", {}).get("lights", [])
    for i, n in enumerate(nodes):
        for c in n.get("children", []):
            if not 0 <= c < len(nodes) or parents[c] is not None:
                problems.add("nodes[%d]" % i, "child %d is missing or has two parents" % c)
            else:
                parents[c] = i
        if "mesh" in n and not 0 <= n["mesh"] < len(g.get("meshes", [])):
            problems.add("nodes[%d]" % i, "mesh %d does not exist" % n["mesh"])
        if "camera" in n and not 0 <= n["camera"] < len(g.get("cameras", [])):
            problems.add("nodes[%d]" % i, "camera %d does not exist" % n["camera"])
        light = n.get("extensions", {}).get("KHR_lights_punctual", {}).get("light")
        if light is not None and not 0 <= light < len(lights):
            problems.add("nodes[%d]" % i, "light %d does not exist" % light)
        if "rotation" in n and abs(math.sqrt(sum(c * c for c in n["rotation"])) - 1.0) > 1e-5:
            problems.add("nodes[%d]" % i, "rotation is not a unit quaternion")
        if "matrix" in n and any(k in n for k in ("translation", "rotation", "scale")):
            problems.add("nodes[%d]" % i, "matrix beside translation/rotation/scale")
        used_extensions.update(n.get("extensions", {}).keys())
    for light in lights:
        if light.get("type") == "spot":
            s = light.get("spot", {})
            if not 0 <= s.get("innerConeAngle", 0) < s.get("outerConeAngle", math.pi / 4) <= math.pi / 2:
                problems.add("light '%s'" % light.get("name"), "cone angles out of order or range")
    missing = used_extensions - set(g.get("extensionsUsed", []))
    if missing:
        problems.add("extensionsUsed", "lacks %s" % ", ".join(sorted(missing)))

    # the scene's triangles: every node reachable from the default scene, instances each time
    instanced = 0
    seen = set()
    stack = list(g["scenes"][g.get("scene", 0)]["nodes"])
    while stack:
        i = stack.pop()
        if i in seen:
            problems.add("nodes[%d]" % i, "reached twice (a cycle or a shared child)")
            continue
        seen.add(i)
        if "mesh" in nodes[i] and nodes[i]["mesh"] < len(mesh_triangles):
            instanced += mesh_triangles[nodes[i]["mesh"]]
        stack.extend(nodes[i].get("children", []))
    for i, p in enumerate(parents):
        if p is None and i not in g["scenes"][g.get("scene", 0)]["nodes"] and i in seen:
            problems.add("nodes[%d]" % i, "a root of the scene is also a child")
    return problems, unique, instanced


def report_check(path):
    problems, unique, instanced = check_gltf(path)
    for p in problems[:50]:
        print("gltf_check.py: %s: %s" % (path, p), file=sys.stderr)
    if problems:
        print("gltf_check.py: %s: %d problems" % (path, len(problems)), file=sys.stderr)
        return 1
    print("%s: valid; %d triangles in its meshes, %d in the scene (instances counted each time)"
          % (path, unique, instanced))
    return 0


if __name__ == "__main__":
    if len(sys.argv) != 2:
        print("usage: gltf_check.py FILE.gltf", file=sys.stderr)
        sys.exit(2)
    sys.exit(report_check(sys.argv[1]))
