#!/usr/bin/env python3
"""The showcase scene of issue 16: a walled courtyard at dusk, as glTF 2.0.

usage: make_showcase.py OUT_DIR [--triangles N] [--check]
       make_showcase.py --check-only FILE.gltf

Writes OUT_DIR/showcase.gltf, showcase.bin, the PNG textures it names (drawn and encoded
by showcase_textures.py with zlib and struct) and showcase.json, a vcmfarm scene that imports the glTF file and looks
at it through a thin lens. Nothing is downloaded; the script uses Python's standard
library only and is deterministic (the same N gives the same bytes).

The scene, in metres, +y up (docs/SCENES.md, "The showcase scene"):
- a paved floor (base colour, metallic-roughness and normal textures, TANGENT attributes)
  inside three brick walls (base colour and normal textures, no TANGENT: the renderer
  derives the frame from the uvs), open to the front and the sky;
- a copper torus-knot sculpture (metallic 1, roughness 0.3) on a stone plinth, lit by a
  spot light (KHR_lights_punctual) on the right wall;
- a rough glass orb (KHR_materials_transmission 1, KHR_materials_ior 1.5, roughness 0.15);
- a garden bed: a displaced soil mound with smooth normals, shrubs of cut-out leaves and
  ferns of cut-out fronds (alphaMode MASK, alphaCutoff 0.5, the base colour's alpha);
- a trellis of cut-out lattice on the back wall with a climbing vine;
- two lantern globes and a glowing doorway (emissiveFactor with
  KHR_materials_emissive_strength);
- a low sun (directional light), a perspective camera, a node hierarchy with translations,
  rotations and scales, and a potted fern in the foreground for the depth of field.

Most triangles are in the knot, the mound, the orb and the leaves; --triangles scales all
of them together (about 1.2 million by default; 20000 is the size the tests use, with
smaller textures).

Light values are written in KHR_lights_punctual's units as Blender writes them and vcmfarm
reads them (docs/SCENES.md, "Light units"): the spot's 120 W/sr as 120 x 683 = 81960 cd,
the sun's 3.2 W/m^2 as 3.2 lux; emitters have radiance of order 1 to 20.

--check reads the files back from disk and verifies them as glTF 2.0 (gltf_check.py: buffer
lengths, accessor bounds and alignment, POSITION min/max, index ranges, unit normals and
tangents, finite uvs, node graph, textures and PNG structure) and prints the triangle
count; it exits 1 with the problems listed. --check-only does that for an existing file.
"""
import argparse
import array
import json
import math
import os
import random
import struct
import sys

import showcase_textures as textures
from gltf_check import report_check

DEFAULT_TRIANGLES = 1_200_000

# Shares of the triangle budget. The rest (walls, plinths, posts, pot, ferns, trellis) is
# about 5,700 triangles whatever the budget.
BUDGET = {
    "knot": 0.33,
    "mound": 0.24,
    "orb": 0.09,
    "globe": 0.015,  # one mesh, two instances
    "shrub_leaves": 0.28,
    "vine_leaves": 0.006,
}


# ---- small vector helpers ---------------------------------------------------------------------

def add(a, b):
    return (a[0] + b[0], a[1] + b[1], a[2] + b[2])


def sub(a, b):
    return (a[0] - b[0], a[1] - b[1], a[2] - b[2])


def mul(a, s):
    return (a[0] * s, a[1] * s, a[2] * s)


def dot(a, b):
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def cross(a, b):
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


def normalize(a):
    n = math.sqrt(dot(a, a))
    return (a[0] / n, a[1] / n, a[2] / n)


def quat_axis_angle(axis, degrees):
    axis = normalize(axis)
    h = math.radians(degrees) / 2
    s = math.sin(h)
    return [axis[0] * s, axis[1] * s, axis[2] * s, math.cos(h)]


def quat_look(forward, up=(0.0, 1.0, 0.0)):
    """The rotation (x, y, z, w) taking the node's -z to `forward` and its +y towards `up`:
    glTF cameras and lights look down their node's -z."""
    f = normalize(forward)
    z = mul(f, -1.0)
    x = normalize(cross(up, z))
    y = cross(z, x)
    m00, m01, m02 = x[0], y[0], z[0]
    m10, m11, m12 = x[1], y[1], z[1]
    m20, m21, m22 = x[2], y[2], z[2]
    tr = m00 + m11 + m22
    if tr > 0:
        s = math.sqrt(tr + 1.0) * 2
        q = [(m21 - m12) / s, (m02 - m20) / s, (m10 - m01) / s, 0.25 * s]
    elif m00 > m11 and m00 > m22:
        s = math.sqrt(1.0 + m00 - m11 - m22) * 2
        q = [0.25 * s, (m01 + m10) / s, (m02 + m20) / s, (m21 - m12) / s]
    elif m11 > m22:
        s = math.sqrt(1.0 + m11 - m00 - m22) * 2
        q = [(m01 + m10) / s, 0.25 * s, (m12 + m21) / s, (m02 - m20) / s]
    else:
        s = math.sqrt(1.0 + m22 - m00 - m11) * 2
        q = [(m02 + m20) / s, (m12 + m21) / s, 0.25 * s, (m10 - m01) / s]
    n = math.sqrt(sum(c * c for c in q))
    return [c / n for c in q]


# ---- meshes ---------------------------------------------------------------------------------------

class Mesh:
    """Flat lists of vertex attributes and triangle indices of one glTF primitive."""

    def __init__(self, tangents=False):
        self.positions, self.normals, self.uvs, self.indices = [], [], [], []
        self.tangents = [] if tangents else None

    def vertex(self, p, n, uv, t=None):
        self.positions.extend(p)
        self.normals.extend(n)
        self.uvs.extend(uv)
        if self.tangents is not None:
            self.tangents.extend(t)
        return len(self.positions) // 3 - 1

    def quad(self, a, b, c, d):
        """Two triangles of the counter-clockwise quad a b c d."""
        self.indices.extend((a, b, c, a, c, d))

    def triangles(self):
        return len(self.indices) // 3


def grid_indices(mesh, first, nu, nv):
    """Quads of a (nu + 1) x (nv + 1) vertex grid, u the fast index."""
    w = nu + 1
    for j in range(nv):
        for i in range(nu):
            a = first + j * w + i
            mesh.quad(a, a + 1, a + 1 + w, a + w)


def knot_mesh(triangles):
    """A (2, 3) torus-knot tube around the origin, about 2.8 units across: each vertex on
    the circle of radius `tube` about the curve, its normal the exact radial direction."""
    ratio = 16  # quads along the curve per quad around the tube
    nv = max(8, int(math.sqrt(triangles / (2 * ratio))))
    nu = max(48, int(triangles / (2 * nv)))
    tube = 0.17

    def curve(t):
        r = 1.0 + 0.42 * math.cos(3 * t)
        return (r * math.cos(2 * t), 0.42 * math.sin(3 * t), r * math.sin(2 * t))

    mesh = Mesh()
    h = 1e-4
    for i in range(nu + 1):
        t = 2 * math.pi * (i % nu) / nu
        c = curve(t)
        d1 = mul(sub(curve(t + h), curve(t - h)), 0.5 / h)
        d2 = mul(add(sub(curve(t + h), mul(c, 2.0)), curve(t - h)), 1.0 / (h * h))
        tangent = normalize(d1)
        normal = normalize(sub(d2, mul(tangent, dot(d2, tangent))))
        binormal = cross(tangent, normal)
        for j in range(nv + 1):
            phi = 2 * math.pi * (j % nv) / nv
            radial = add(mul(normal, math.cos(phi)), mul(binormal, math.sin(phi)))
            radial = normalize(radial)
            mesh.vertex(add(c, mul(radial, tube)), radial, (6.0 * i / nu, j / nv))
    # winding: first around the tube, then along it, so the quads face outwards
    w = nv + 1
    for i in range(nu):
        for j in range(nv):
            a = i * w + j
            mesh.quad(a, a + 1, a + w + 1, a + w)
    return mesh


def sphere_mesh(triangles, radius, uv_scale=1.0):
    """A uv sphere; one triangle per cell at each pole ring, so no degenerate triangles."""
    rings = max(6, int(math.sqrt(triangles / 4)))
    segments = 2 * rings
    mesh = Mesh()
    for j in range(rings + 1):
        theta = math.pi * j / rings
        for i in range(segments + 1):
            phi = 2 * math.pi * (i % segments) / segments
            n = (math.sin(theta) * math.cos(phi), math.cos(theta), -math.sin(theta) * math.sin(phi))
            if j == 0:
                n = (0.0, 1.0, 0.0)
            elif j == rings:
                n = (0.0, -1.0, 0.0)
            mesh.vertex(mul(n, radius), n, (uv_scale * i / segments, uv_scale * j / rings))
    w = segments + 1
    for j in range(rings):
        for i in range(segments):
            a = j * w + i
            b, c, d = a + 1, a + w + 1, a + w
            if j == 0:
                mesh.indices.extend((a, d, c))
            elif j == rings - 1:
                mesh.indices.extend((a, d, b))
            else:
                mesh.indices.extend((a, d, c, a, c, b))
    return mesh


def lathe_mesh(profile, segments):
    """A surface of revolution about +y of `profile`, a list of (radius, y) points from the
    bottom up. A point given twice is a hard edge (each copy takes the normal of its own
    side); elsewhere the normal follows the profile's slope. A ring of radius 0 is a pole:
    its band is a fan of single triangles, so no triangle is degenerate."""
    mesh = Mesh()
    count = len(profile)
    rings = []
    for k, (r, y) in enumerate(profile):
        prev = k - 1 if k > 0 and profile[k - 1] != profile[k] else k
        nxt = k + 1 if k + 1 < count and profile[k + 1] != profile[k] else k
        (r0, y0), (r1, y1) = profile[prev], profile[nxt]
        dr, dy = r1 - r0, y1 - y0
        ln = math.hypot(dr, dy)
        nr, ny = dy / ln, -dr / ln  # outward normal of the profile
        first = len(mesh.positions) // 3
        for i in range(segments + 1):
            phi = 2 * math.pi * (i % segments) / segments
            c, s = math.cos(phi), -math.sin(phi)
            mesh.vertex((r * c, y, r * s), (nr * c, ny, nr * s), (i / segments, 1.0 - k / (count - 1)))
        rings.append(first)
    for k in range(count - 1):
        if profile[k] == profile[k + 1]:
            continue
        lo, hi = rings[k], rings[k + 1]
        for i in range(segments):
            a, b, c, d = lo + i, lo + i + 1, hi + i + 1, hi + i
            if profile[k][0] == 0.0:
                mesh.indices.extend((a, c, d))
            elif profile[k + 1][0] == 0.0:
                mesh.indices.extend((a, b, d))
            else:
                mesh.quad(a, b, c, d)
    return mesh


def box_mesh(lo, hi, tile_u=1.0, tile_v=0.9, with_tangents=False):
    """An axis-aligned box, four vertices a face, uvs in metres over the tile size (u along
    the face, v downwards from the top, as an image is)."""
    mesh = Mesh(tangents=with_tangents)
    (x0, y0, z0), (x1, y1, z1) = lo, hi
    # each face: origin corner (top-left seen from outside), right axis, down axis, normal
    faces = [
        ((x0, y1, z1), (1, 0, 0), (0, -1, 0), (0, 0, 1), x1 - x0, y1 - y0),   # +z
        ((x1, y1, z0), (-1, 0, 0), (0, -1, 0), (0, 0, -1), x1 - x0, y1 - y0),  # -z
        ((x1, y1, z1), (0, 0, -1), (0, -1, 0), (1, 0, 0), z1 - z0, y1 - y0),   # +x
        ((x0, y1, z0), (0, 0, 1), (0, -1, 0), (-1, 0, 0), z1 - z0, y1 - y0),   # -x
        ((x0, y1, z0), (1, 0, 0), (0, 0, 1), (0, 1, 0), x1 - x0, z1 - z0),     # +y
        ((x0, y0, z1), (1, 0, 0), (0, 0, -1), (0, -1, 0), x1 - x0, z1 - z0),   # -y
    ]
    for origin, right, down, n, w, h in faces:
        ou = dot(origin, right) / tile_u
        ov = dot(origin, down) / tile_v
        first = len(mesh.positions) // 3
        for (a, b) in ((0, 0), (1, 0), (1, 1), (0, 1)):
            p = add(origin, add(mul(right, a * w), mul(down, b * h)))
            uv = (ou + a * w / tile_u, ov + b * h / tile_v)
            mesh.vertex(p, n, uv, (right[0], right[1], right[2], 1.0) if with_tangents else None)
        # corners run right then down: clockwise seen from outside, so reverse
        mesh.indices.extend((first, first + 3, first + 2, first, first + 2, first + 1))
    return mesh


def floor_mesh(x0, x1, z0, z1, tile):
    """The paving: a subdivided plane at y = 0 facing +y, u along +x and v along +z in
    tiles, with TANGENT attributes (+x, bitangent cross(n, t) = -z: up in the image)."""
    mesh = Mesh(tangents=True)
    nx, nz = 12, 12
    for j in range(nz + 1):
        z = z0 + (z1 - z0) * j / nz
        for i in range(nx + 1):
            x = x0 + (x1 - x0) * i / nx
            mesh.vertex((x, 0.0, z), (0.0, 1.0, 0.0), (x / tile, z / tile), (1.0, 0.0, 0.0, 1.0))
    w = nx + 1
    for j in range(nz):
        for i in range(nx):
            a = j * w + i
            mesh.quad(a, a + w, a + w + 1, a + 1)
    return mesh


class Mound:
    """The garden bed's soil: a smooth bump with noise over a rectangle, zero at its rim."""

    def __init__(self, x0, x1, z0, z1, peak):
        self.x0, self.x1, self.z0, self.z1, self.peak = x0, x1, z0, z1, peak

    def height(self, x, z):
        sx = (x - self.x0) / (self.x1 - self.x0)
        sz = (z - self.z0) / (self.z1 - self.z0)
        if not (0.0 <= sx <= 1.0 and 0.0 <= sz <= 1.0):
            return 0.0
        bump = (math.sin(math.pi * sx) * math.sin(math.pi * sz)) ** 0.6
        n = 0.0
        amplitude, freq = 0.5, 1.3
        for octave in range(4):
            n += amplitude * (textures.smooth_noise2(x * freq, z * freq, 31 + octave) - 0.5)
            amplitude *= 0.5
            freq *= 2.1
        return 0.015 + bump * (self.peak + 0.12 * n)

    def mesh(self, triangles):
        aspect = (self.x1 - self.x0) / (self.z1 - self.z0)
        nz = max(4, int(math.sqrt(triangles / (2 * aspect))))
        nx = max(4, int(triangles / (2 * nz)))
        dx, dz = (self.x1 - self.x0) / nx, (self.z1 - self.z0) / nz
        # heights with a ring of ghost samples for the normals' central differences
        hs = [[self.height(self.x0 + (i - 1) * dx, self.z0 + (j - 1) * dz) for i in range(nx + 3)]
              for j in range(nz + 3)]
        mesh = Mesh()
        for j in range(nz + 1):
            z = self.z0 + j * dz
            row, above, below = hs[j + 1], hs[j], hs[j + 2]
            for i in range(nx + 1):
                x = self.x0 + i * dx
                gx = (row[i + 2] - row[i]) / (2 * dx)
                gz = (below[i + 1] - above[i + 1]) / (2 * dz)
                mesh.vertex((x, row[i + 1], z), normalize((-gx, 1.0, -gz)), (x / 1.5, z / 1.5))
        w = nx + 1
        for j in range(nz):
            for i in range(nx):
                a = j * w + i
                mesh.quad(a, a + w, a + w + 1, a + 1)
        return mesh


def leaf_quad(mesh, base, along, normal, length, width):
    """A cut-out leaf: a quad from its stalk at `base` to its tip along `along`, facing
    `normal` (counter-clockwise seen from it); u across, v from the tip (0) to the stalk (1)."""
    side = normalize(cross(along, normal))
    half = mul(side, width / 2)
    tip = add(base, mul(along, length))
    a = mesh.vertex(sub(base, half), normal, (0.0, 1.0))
    b = mesh.vertex(add(base, half), normal, (1.0, 1.0))
    c = mesh.vertex(add(tip, half), normal, (1.0, 0.0))
    d = mesh.vertex(sub(tip, half), normal, (0.0, 0.0))
    mesh.quad(a, b, c, d)


def random_unit(rng):
    while True:
        v = (rng.uniform(-1, 1), rng.uniform(-1, 1), rng.uniform(-1, 1))
        d = dot(v, v)
        if 1e-4 < d <= 1.0:
            return mul(v, 1.0 / math.sqrt(d))


def leaf_frame(rng, outward, tilt):
    """A leaf's direction and normal: the normal turned from `outward` by up to `tilt`, the
    direction random in its plane but leaning upwards, as leaves face the light."""
    n = normalize(add(outward, mul(random_unit(rng), tilt)))
    n = normalize(add(n, (0.0, 0.35, 0.0)))
    r = random_unit(rng)
    along = sub(r, mul(n, dot(r, n)))
    if dot(along, along) < 1e-6:
        along = cross(n, (1.0, 0.0, 0.0))
    return normalize(along), n


def ellipsoid_area(radii):
    """Knud Thomsen's approximation of an ellipsoid's surface area (within about 1%)."""
    a, b, c = radii
    p = 1.6075
    return 4 * math.pi * (((a * b) ** p + (a * c) ** p + (b * c) ** p) / 3) ** (1 / p)


# The part of a leaf texture's square the leaf covers (its alpha above the cutoff).
LEAF_FILL = 0.62 * 0.6


def shrub_leaves(mesh, rng, centre, radii, count, size):
    """`count` leaves in an ellipsoidal crown, most near its surface."""
    for _ in range(count):
        d = random_unit(rng)
        depth = 0.55 + 0.45 * rng.random() ** 0.5
        p = (centre[0] + radii[0] * d[0] * depth, centre[1] + radii[1] * d[1] * depth,
             centre[2] + radii[2] * d[2] * depth)
        along, n = leaf_frame(rng, d, 0.8)
        scale = size * rng.uniform(0.75, 1.25)
        leaf_quad(mesh, p, along, n, scale, scale * 0.62)


def fern(mesh, rng, base, fronds, length, segments):
    """A fern: fronds arching out of `base`, each a strip of `segments` quads bent under
    its own weight, smooth normals along it."""
    for f in range(fronds):
        phi = 2 * math.pi * (f + rng.random() * 0.6) / fronds
        hdir = (math.cos(phi), 0.0, math.sin(phi))
        side = (-math.sin(phi), 0.0, math.cos(phi))
        elev = math.radians(rng.uniform(45, 75))
        droop = math.radians(rng.uniform(80, 130))
        L = length * rng.uniform(0.75, 1.15)
        width = 0.42 * L
        p = base
        ds = L / segments
        first = len(mesh.positions) // 3
        for k in range(segments + 1):
            s = k / segments
            theta = elev - droop * s
            t = add(mul(hdir, math.cos(theta)), (0.0, math.sin(theta), 0.0))
            n = cross(side, t)
            half = mul(side, width / 2)
            mesh.vertex(sub(p, half), n, (0.0, 1.0 - s))
            mesh.vertex(add(p, half), n, (1.0, 1.0 - s))
            p = add(p, mul(t, ds))
        for k in range(segments):
            a = first + 2 * k
            mesh.quad(a, a + 1, a + 3, a + 2)


# ---- the scene ----------------------------------------------------------------------------------

class Builder:
    """glTF 2.0 JSON and one binary buffer, grown as meshes and nodes are added."""

    def __init__(self):
        self.bin = bytearray()
        self.gltf = {
            "asset": {"version": "2.0", "generator": "vcmfarm tests/bench/make_showcase.py"},
            "extensionsUsed": ["KHR_lights_punctual", "KHR_materials_emissive_strength",
                               "KHR_materials_transmission", "KHR_materials_ior"],
            "scene": 0, "scenes": [{"name": "Courtyard", "nodes": []}],
            "nodes": [], "meshes": [], "materials": [], "textures": [], "images": [], "samplers": [],
            "accessors": [], "bufferViews": [], "buffers": [], "cameras": [],
            "extensions": {"KHR_lights_punctual": {"lights": []}},
        }
        self.unique_triangles = 0

    def _view(self, data, target):
        while len(self.bin) % 4:
            self.bin.append(0)
        self.gltf["bufferViews"].append({"buffer": 0, "byteOffset": len(self.bin), "byteLength": len(data),
                                         "target": target})
        self.bin.extend(data)
        return len(self.gltf["bufferViews"]) - 1

    def _accessor(self, values, kind, width, component, target, bounds=False):
        typed = array.array("I" if component == 5125 else "f", values)
        if sys.byteorder != "little":
            typed.byteswap()
        accessor = {"bufferView": self._view(typed.tobytes(), target), "componentType": component,
                    "count": len(values) // width, "type": kind}
        if bounds:
            accessor["min"] = [min(values[k::width]) for k in range(width)]
            accessor["max"] = [max(values[k::width]) for k in range(width)]
            # the bounds of the stored single-precision values
            accessor["min"] = [struct.unpack("<f", struct.pack("<f", v))[0] for v in accessor["min"]]
            accessor["max"] = [struct.unpack("<f", struct.pack("<f", v))[0] for v in accessor["max"]]
        self.gltf["accessors"].append(accessor)
        return len(self.gltf["accessors"]) - 1

    def mesh(self, name, mesh, material):
        attributes = {
            "POSITION": self._accessor(mesh.positions, "VEC3", 3, 5126, 34962, bounds=True),
            "NORMAL": self._accessor(mesh.normals, "VEC3", 3, 5126, 34962),
            "TEXCOORD_0": self._accessor(mesh.uvs, "VEC2", 2, 5126, 34962),
        }
        if mesh.tangents is not None:
            attributes["TANGENT"] = self._accessor(mesh.tangents, "VEC4", 4, 5126, 34962)
        primitive = {"attributes": attributes, "indices": self._accessor(mesh.indices, "SCALAR", 1, 5125, 34963),
                     "material": material, "mode": 4}
        self.gltf["meshes"].append({"name": name, "primitives": [primitive]})
        self.unique_triangles += mesh.triangles()
        return len(self.gltf["meshes"]) - 1

    def image(self, out_dir, name, width, channels, pixels):
        with open(os.path.join(out_dir, name), "wb") as f:
            f.write(textures.png_bytes(width, width, channels, pixels))
        self.gltf["images"].append({"uri": name, "mimeType": "image/png"})
        if not self.gltf["samplers"]:
            # linear filtering, repeat: the default wrap, stated for readers
            self.gltf["samplers"].append({"magFilter": 9729, "minFilter": 9987, "wrapS": 10497, "wrapT": 10497})
        self.gltf["textures"].append({"source": len(self.gltf["images"]) - 1, "sampler": 0})
        return len(self.gltf["textures"]) - 1

    def material(self, spec):
        self.gltf["materials"].append(spec)
        return len(self.gltf["materials"]) - 1

    def node(self, spec, parent=None):
        nodes = self.gltf["nodes"]
        nodes.append(spec)
        index = len(nodes) - 1
        if parent is None:
            self.gltf["scenes"][0]["nodes"].append(index)
        else:
            nodes[parent].setdefault("children", []).append(index)
        return index

    def finish(self, out_dir, stem):
        """Writes stem.bin and stem.gltf."""
        while len(self.bin) % 4:
            self.bin.append(0)
        self.gltf["buffers"].append({"uri": stem + ".bin", "byteLength": len(self.bin)})
        with open(os.path.join(out_dir, stem + ".bin"), "wb") as f:
            f.write(self.bin)
        with open(os.path.join(out_dir, stem + ".gltf"), "w") as f:
            json.dump(self.gltf, f, indent=1)
            f.write("\n")

    def light(self, spec):
        lights = self.gltf["extensions"]["KHR_lights_punctual"]["lights"]
        lights.append(spec)
        return len(lights) - 1


def pbr(name, base=(1, 1, 1, 1), metallic=0.0, roughness=1.0, base_texture=None, mr_texture=None, **extra):
    m = {"name": name, "pbrMetallicRoughness": {"baseColorFactor": list(base), "metallicFactor": metallic,
                                                "roughnessFactor": roughness}}
    if base_texture is not None:
        m["pbrMetallicRoughness"]["baseColorTexture"] = {"index": base_texture}
    if mr_texture is not None:
        m["pbrMetallicRoughness"]["metallicRoughnessTexture"] = {"index": mr_texture}
    m.update(extra)
    return m


# Where things stand (metres): the courtyard's floor is [-6, 6] x [-6, 6.5], walls 4 m high
# on the left (x = -6), back (z = -6) and right (x = 6); the camera looks in from the front,
# tilted down so that the walls fill the top of the picture and no empty sky shows.
HALF, WALL_H, WALL_T = 6.0, 4.0, 0.3
CAMERA_POS, CAMERA_TARGET = (0.3, 1.5, 3.2), (0.5, 0.9, -3.0)
CAMERA_YFOV = math.radians(42.0)
KNOT_AT = (3.7, 0.0, -3.0)
ORB_AT = (-0.6, 0.0, -1.4)
SPOT_AT = (5.7, 3.2, -0.5)
SUN_TRAVELS = (-0.55, -0.62, -0.56)  # from the front right, over the right wall
BED = (-HALF + 0.05, -1.7, -HALF + 0.05, -2.1)  # x0, x1, z0, z1 of the garden bed


def add_materials(b, t):
    """The scene's materials, by name, over the texture indices `t`."""
    cut_out = {"alphaMode": "MASK", "alphaCutoff": 0.5, "doubleSided": True}
    glow = lambda colour, strength: {"emissiveFactor": colour, "extensions": {
        "KHR_materials_emissive_strength": {"emissiveStrength": strength}}}
    specs = [
        # metallic factor 1 times the texture's blue (0): a dielectric; roughness from green
        pbr("paving", metallic=1.0, roughness=1.0, base_texture=t["paving_basecolor"],
            mr_texture=t["paving_metallic_roughness"], normalTexture={"index": t["paving_normal"], "scale": 1.0}),
        pbr("brick", roughness=0.85, base_texture=t["brick_basecolor"],
            normalTexture={"index": t["brick_normal"], "scale": 1.0}),
        pbr("copper", base=(0.955, 0.638, 0.538, 1), metallic=1.0, roughness=0.3),
        pbr("rough glass", base=(0.97, 0.99, 1.0, 1), roughness=0.15, extensions={
            "KHR_materials_transmission": {"transmissionFactor": 1.0}, "KHR_materials_ior": {"ior": 1.5}}),
        pbr("leaf", roughness=0.6, base_texture=t["leaf_basecolor"], **cut_out),
        pbr("fern frond", roughness=0.65, base_texture=t["frond_basecolor"], **cut_out),
        pbr("trellis", roughness=0.8, base_texture=t["trellis_basecolor"], **cut_out),
        pbr("soil", roughness=0.95, base_texture=t["soil_basecolor"]),
        pbr("limestone", base=(0.62, 0.58, 0.52, 1), roughness=0.7),
        pbr("wrought iron", base=(0.36, 0.35, 0.34, 1), metallic=1.0, roughness=0.45),
        pbr("terracotta", base=(0.55, 0.25, 0.14, 1), roughness=0.8),
        pbr("lantern glow", base=(0.8, 0.8, 0.8, 1), roughness=0.5, **glow([1.0, 0.72, 0.42], 14.0)),
        pbr("doorway glow", base=(0.0, 0.0, 0.0, 1), roughness=1.0, **glow([1.0, 0.78, 0.55], 1.1)),
    ]
    return {spec["name"]: b.material(spec) for spec in specs}


def add_architecture(b, m, root):
    arch = b.node({"name": "Architecture"}, root)
    b.node({"name": "Paving", "mesh": b.mesh("paving", floor_mesh(-HALF, HALF, -HALF, HALF + 0.5, 2.4), m["paving"])},
           arch)
    walls = b.node({"name": "Walls"}, arch)
    boxes = [
        ("back wall", (-HALF - WALL_T, 0.0, -HALF - WALL_T), (HALF + WALL_T, WALL_H, -HALF), "brick"),
        ("left wall", (-HALF - WALL_T, 0.0, -HALF), (-HALF, WALL_H, HALF + 0.5), "brick"),
        ("right wall", (HALF, 0.0, -HALF), (HALF + WALL_T, WALL_H, HALF + 0.5), "brick"),
    ]
    for name, lo, hi, material in boxes:
        b.node({"name": name, "mesh": b.mesh(name, box_mesh(lo, hi), m[material])}, walls)
    # the coping stones: one box mesh, scaled and placed along each wall's top
    coping = b.mesh("coping", box_mesh((-0.5, 0.0, -0.5), (0.5, 1.0, 0.5), 0.5, 0.5), m["limestone"])
    span = 2 * HALF + 2 * WALL_T + 0.1
    for name, t, s in (("back coping", [0.0, WALL_H, -HALF - WALL_T / 2], [span, 0.1, WALL_T + 0.1]),
                       ("left coping", [-HALF - WALL_T / 2, WALL_H, 0.25], [WALL_T + 0.1, 0.1, 2 * HALF + 0.5]),
                       ("right coping", [HALF + WALL_T / 2, WALL_H, 0.25], [WALL_T + 0.1, 0.1, 2 * HALF + 0.5])):
        b.node({"name": name, "mesh": coping, "translation": t, "scale": s}, walls)
    door = Mesh()
    dz = -HALF + 0.01
    for p, uv in (((-0.65, 0.0, dz), (0, 1)), ((0.65, 0.0, dz), (1, 1)), ((0.65, 2.3, dz), (1, 0)),
                  ((-0.65, 2.3, dz), (0, 0))):
        door.vertex(p, (0.0, 0.0, 1.0), uv)
    door.quad(0, 1, 2, 3)
    b.node({"name": "Doorway", "mesh": b.mesh("doorway", door, m["doorway glow"])}, arch)
    frame = b.node({"name": "Door frame", "translation": [0.0, 0.0, dz + 0.08]}, arch)
    jamb = b.mesh("door jamb", box_mesh((-0.08, 0.0, -0.08), (0.08, 1.0, 0.08), 0.5, 0.5), m["limestone"])
    b.node({"name": "Jamb left", "mesh": jamb, "translation": [-0.73, 0.0, 0.0], "scale": [1, 2.3, 1]}, frame)
    b.node({"name": "Jamb right", "mesh": jamb, "translation": [0.73, 0.0, 0.0], "scale": [1, 2.3, 1]}, frame)
    b.node({"name": "Lintel", "mesh": jamb, "translation": [0.81, 2.3, 0.0], "scale": [1, 1.62, 1],
            "rotation": quat_axis_angle((0, 0, 1), 90)}, frame)


def add_sculptures(b, m, root, budget):
    # the copper knot on its plinth; the knot's own node is tilted and scaled
    sculpture = b.node({"name": "Sculpture", "translation": list(KNOT_AT),
                        "rotation": quat_axis_angle((0, 1, 0), 25)}, root)
    plinth = lathe_mesh([(0.0, 0.0), (0.42, 0.0), (0.42, 0.0), (0.42, 0.08), (0.42, 0.08), (0.34, 0.12),
                         (0.34, 0.12), (0.3, 0.75), (0.3, 0.75), (0.36, 0.8), (0.36, 0.8), (0.36, 0.86),
                         (0.36, 0.86), (0.0, 0.86)], 96)
    b.node({"name": "Plinth", "mesh": b.mesh("plinth", plinth, m["limestone"])}, sculpture)
    b.node({"name": "Knot", "mesh": b.mesh("knot", knot_mesh(budget["knot"]), m["copper"]),
            "translation": [0.0, 1.6, 0.0], "rotation": quat_axis_angle((1, 0, 0.3), 62), "scale": [0.5, 0.5, 0.5]},
           sculpture)

    # the glass orb on a short plinth
    orb = b.node({"name": "Glass orb", "translation": list(ORB_AT)}, root)
    pedestal = lathe_mesh([(0.0, 0.0), (0.3, 0.0), (0.3, 0.0), (0.3, 0.06), (0.3, 0.06), (0.18, 0.12), (0.15, 0.5),
                           (0.24, 0.56), (0.24, 0.56), (0.0, 0.56)], 96)
    b.node({"name": "Orb plinth", "mesh": b.mesh("orb plinth", pedestal, m["limestone"])}, orb)
    b.node({"name": "Orb", "mesh": b.mesh("orb", sphere_mesh(budget["orb"], 0.5), m["rough glass"]),
            "translation": [0.0, 1.06, 0.0]}, orb)

    # lanterns flanking the doorway: one globe mesh and one post mesh, two instances each
    globe = b.mesh("lantern globe", sphere_mesh(budget["globe"], 0.14), m["lantern glow"])
    post = b.mesh("lantern post", lathe_mesh([(0.0, 0.0), (0.09, 0.0), (0.09, 0.0), (0.09, 0.05), (0.035, 0.1),
                                              (0.03, 1.5), (0.07, 1.55), (0.07, 1.55), (0.07, 1.58), (0.07, 1.58),
                                              (0.0, 1.58)], 48), m["wrought iron"])
    for k, x in enumerate((-1.35, 1.35)):
        lantern = b.node({"name": "Lantern %d" % (k + 1), "translation": [x, 0.0, -HALF + 0.45]}, root)
        b.node({"name": "Post", "mesh": post}, lantern)
        b.node({"name": "Globe", "mesh": globe, "translation": [0.0, 1.72, 0.0]}, lantern)


def add_garden(b, m, root, budget, rng):
    garden = b.node({"name": "Garden"}, root)
    bed = Mound(*BED, peak=0.35)
    b.node({"name": "Soil", "mesh": b.mesh("soil", bed.mesh(budget["mound"]), m["soil"])}, garden)
    kerb = b.mesh("kerb", box_mesh((-0.5, 0.0, -0.06), (0.5, 0.16, 0.06), 0.5, 0.5), m["limestone"])
    width, depth = bed.x1 - bed.x0, bed.z1 - bed.z0
    b.node({"name": "Kerb front", "mesh": kerb, "translation": [(bed.x0 + bed.x1) / 2 + 0.06, 0.0, bed.z1 + 0.06],
            "scale": [width + 0.12, 1.0, 1.0]}, garden)
    b.node({"name": "Kerb side", "mesh": kerb, "translation": [bed.x1 + 0.06, 0.0, (bed.z0 + bed.z1) / 2],
            "rotation": quat_axis_angle((0, 1, 0), 90), "scale": [depth, 1.0, 1.0]}, garden)

    # shrubs: crowns of leaves sized so that every crown is covered about twice over
    shrubs = [((-4.9, -5.0), (0.75, 0.85, 0.7)), ((-3.4, -5.2), (0.7, 0.65, 0.55)),
              ((-5.2, -3.4), (0.55, 0.6, 0.6)), ((-2.5, -4.4), (0.5, 0.45, 0.5)),
              ((-4.0, -3.3), (0.45, 0.42, 0.45))]
    leaves = budget["shrub_leaves"] // 2
    total_area = sum(ellipsoid_area(r) for _, r in shrubs)
    shrub_mesh = Mesh()
    for (x, z), radii in shrubs:
        area = ellipsoid_area(radii)
        count = max(20, int(leaves * area / total_area))
        size = min(0.35, math.sqrt(2.2 * area / (count * LEAF_FILL)))
        centre = (x, bed.height(x, z) + radii[1] * 0.85, z)
        shrub_leaves(shrub_mesh, rng, centre, radii, count, size)
    b.node({"name": "Shrubs", "mesh": b.mesh("shrub leaves", shrub_mesh, m["leaf"])}, garden)

    # ferns in the bed and, nearest the camera, in a pot (out of focus in showcase.json)
    fern_mesh = Mesh()
    for x, z in [(-2.3, -2.7), (-3.2, -2.6), (-2.1, -3.5), (-4.6, -2.5), (-3.0, -3.9), (-5.4, -4.5), (-4.1, -4.4)]:
        fern(fern_mesh, rng, (x, bed.height(x, z) + 0.02, z), 11, rng.uniform(0.55, 0.8), 10)
    b.node({"name": "Ferns", "mesh": b.mesh("ferns", fern_mesh, m["fern frond"])}, garden)
    potted = b.node({"name": "Potted fern", "translation": [-1.15, 0.0, 1.1],
                     "rotation": quat_axis_angle((0, 1, 0), 40), "scale": [1.1, 1.1, 1.1]}, root)
    pot = lathe_mesh([(0.0, 0.0), (0.16, 0.0), (0.16, 0.0), (0.2, 0.05), (0.25, 0.42), (0.28, 0.44), (0.28, 0.48),
                      (0.28, 0.48), (0.24, 0.48), (0.24, 0.48), (0.23, 0.44), (0.0, 0.40)], 64)
    b.node({"name": "Pot", "mesh": b.mesh("pot", pot, m["terracotta"])}, potted)
    potted_mesh = Mesh()
    fern(potted_mesh, rng, (0.0, 0.42, 0.0), 14, 0.75, 10)
    b.node({"name": "Fern", "mesh": b.mesh("potted fern", potted_mesh, m["fern frond"])}, potted)

    # a trellis on the back wall above the bed, with a vine climbing it
    tw, th = 3.6, 3.0
    trellis = b.node({"name": "Trellis", "translation": [-3.85, 0.5, -HALF + 0.06]}, root)
    panel = Mesh()
    for p, uv in (((-tw / 2, 0.0, 0.0), (0, th / 0.6)), ((tw / 2, 0.0, 0.0), (tw / 0.6, th / 0.6)),
                  ((tw / 2, th, 0.0), (tw / 0.6, 0)), ((-tw / 2, th, 0.0), (0, 0))):
        panel.vertex(p, (0.0, 0.0, 1.0), uv)
    panel.quad(0, 1, 2, 3)
    b.node({"name": "Lattice", "mesh": b.mesh("trellis", panel, m["trellis"])}, trellis)
    vine = Mesh()
    count = max(30, budget["vine_leaves"] // 2)
    # the leaves' area is a fifth of the panel's, whatever their number
    size = min(0.3, math.sqrt(0.2 * tw * th / (count * LEAF_FILL)))
    stems = (-1.2, 0.1, 1.1)
    for k in range(count):
        s = rng.random() ** 0.6
        y = 0.6 + s * (th - 0.6)
        x = stems[k % 3] + 0.35 * math.sin(2.5 * y + k % 3) + rng.gauss(0, 0.15 + 0.25 * s)
        x = max(-tw / 2 + 0.05, min(tw / 2 - 0.05, x))
        along, n = leaf_frame(rng, (0.0, 0.0, 1.0), 0.6)
        if n[2] < 0.3:
            n = normalize((n[0], n[1], 0.3))
            along = normalize(sub(along, mul(n, dot(along, n))))
        leaf_quad(vine, (x, y, 0.04 + 0.08 * rng.random()), along, n, size * rng.uniform(0.8, 1.2), size * 0.62)
    b.node({"name": "Vine", "mesh": b.mesh("vine leaves", vine, m["leaf"])}, trellis)


def add_lights_and_camera(b, m, root):
    # a spot high on the right wall, aimed at the knot, which stands in that wall's shadow
    aim = sub((KNOT_AT[0], 1.3, KNOT_AT[2]), SPOT_AT)
    rig = b.node({"name": "Spot rig", "translation": list(SPOT_AT), "rotation": quat_look(aim)}, root)
    # the housing's axis is its lathe's +y, turned to +z: behind the light, which looks down -z
    housing = lathe_mesh([(0.0, 0.0), (0.09, 0.0), (0.11, 0.2), (0.11, 0.22), (0.11, 0.22), (0.0, 0.26)], 48)
    b.node({"name": "Spot housing", "mesh": b.mesh("spot housing", housing, m["wrought iron"]),
            "translation": [0.0, 0.0, 0.02], "rotation": quat_axis_angle((1, 0, 0), 90)}, rig)
    spot = b.light({"name": "spot", "type": "spot", "color": [1.0, 0.93, 0.82], "intensity": 120.0 * 683.0,
                    "spot": {"innerConeAngle": math.radians(12), "outerConeAngle": math.radians(20)}})
    b.node({"name": "Spot", "extensions": {"KHR_lights_punctual": {"light": spot}}}, rig)
    sun = b.light({"name": "sun", "type": "directional", "color": [1.0, 0.86, 0.7], "intensity": 3.2})
    b.node({"name": "Sun", "rotation": quat_look(SUN_TRAVELS, (0.0, 0.0, -1.0)),
            "extensions": {"KHR_lights_punctual": {"light": sun}}}, root)
    b.gltf["cameras"].append({"name": "Visitor", "type": "perspective", "perspective": {
        "yfov": CAMERA_YFOV, "aspectRatio": 16 / 9, "znear": 0.05, "zfar": 100.0}})
    b.node({"name": "Camera", "camera": 0, "translation": list(CAMERA_POS),
            "rotation": quat_look(sub(CAMERA_TARGET, CAMERA_POS))}, root)


def build(out_dir, triangles):
    """Writes the scene's files into out_dir; returns the number of triangles in its meshes."""
    rng = random.Random(16)
    b = Builder()
    budget = {k: int(v * triangles) for k, v in BUDGET.items()}
    size = 512 if triangles >= 400_000 else 128  # the paving and brick maps; the others half
    small = size // 2
    t = {}
    for name, width, channels, pixels in textures.all_textures(rng, size, small):
        t[name] = b.image(out_dir, name + ".png", width, channels, pixels)
    m = add_materials(b, t)
    root = b.node({"name": "Courtyard"})
    add_architecture(b, m, root)
    add_sculptures(b, m, root, budget)
    add_garden(b, m, root, budget, rng)
    add_lights_and_camera(b, m, root)
    b.finish(out_dir, "showcase")
    write_wrapper(out_dir)
    return b.unique_triangles


def write_wrapper(out_dir):
    """showcase.json: the glTF file imported whole (docs/SCENES.md, "import") and seen from
    its camera's place through a thin lens focused on the glass orb, at 1920 x 1080."""
    forward = normalize(sub(CAMERA_TARGET, CAMERA_POS))
    orb_centre = (ORB_AT[0], 1.06, ORB_AT[2])
    scene = {
        "camera": {"position": list(CAMERA_POS), "forward": [round(c, 6) for c in forward], "up": [0, 1, 0],
                   "fov": round(math.degrees(CAMERA_YFOV), 6), "resolution": [1920, 1080],
                   "aperture": 0.025, "focus_distance": round(dot(sub(orb_centre, CAMERA_POS), forward), 4)},
        "import": [{"file": "showcase.gltf"}],
    }
    with open(os.path.join(out_dir, "showcase.json"), "w") as f:
        json.dump(scene, f, indent=2)
        f.write("\n")


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("out_dir", nargs="?", help="directory to write showcase.gltf and its files into")
    parser.add_argument("--triangles", type=int, default=DEFAULT_TRIANGLES,
                        help="triangle budget (default %d)" % DEFAULT_TRIANGLES)
    parser.add_argument("--check", action="store_true", help="verify the written files as glTF 2.0")
    parser.add_argument("--check-only", metavar="GLTF", help="verify an existing file and write nothing")
    args = parser.parse_args()
    if args.check_only:
        return report_check(args.check_only)
    if args.out_dir is None:
        parser.error("OUT_DIR is required")
    if args.triangles < 5000:
        parser.error("--triangles must be at least 5000")
    os.makedirs(args.out_dir, exist_ok=True)
    triangles = build(args.out_dir, args.triangles)
    print("%s: %d triangles" % (os.path.join(args.out_dir, "showcase.gltf"), triangles))
    if args.check:
        return report_check(os.path.join(args.out_dir, "showcase.gltf"))
    return 0


if __name__ == "__main__":
    sys.exit(main())
