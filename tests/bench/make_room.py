#!/usr/bin/env python3
"""The benchmark room of issue 42: a closed interior lit by a point and a spot light, as glTF 2.0.

usage: make_room.py OUT_DIR [--check]

Writes OUT_DIR/room.gltf and room.bin. Nothing is downloaded; the script uses Python's
standard library only (and make_showcase.py's glTF builder and meshes) and is
deterministic. `vcmfarm render OUT_DIR/room.gltf` renders it from its own camera.

The scene, in metres, +y up: a room 5 x 2.8 x 4.5, closed on every side, its walls a matte
off-white, the floor a glossy dark wood (roughness 0.35), the ceiling white; a table in the
middle holding a gold sphere (metallic 1, roughness 0.2) and a rough glass vase
(KHR_materials_transmission 1, KHR_materials_ior 1.5, roughness 0.15); a chrome bowl
(metallic 1, roughness 0.05) on the floor left of the table; a leaf (a thin double-sided
blade) beside the sphere. Two lights (KHR_lights_punctual, in the units Blender writes and
vcmfarm reads, docs/SCENES.md "Light units"): a point light under the ceiling, 9 W/sr
(6147 cd), and a spot in the right back corner aimed at the sphere, 70 W/sr (47810 cd),
cone 10 to 16 degrees. No light is seen directly; most of the room is lit indirectly, and
what the spot lights on the table is seen again in the glossy floor and the bowl: the
transport that issue 42's per-pixel technique choice is about.

--check reads the files back and verifies them as glTF 2.0 (gltf_check.py); it exits 1
with the problems listed.
"""
import argparse
import math
import os
import sys

from gltf_check import report_check
from make_showcase import Builder, Mesh, box_mesh, lathe_mesh, pbr, quat_axis_angle, quat_look, sphere_mesh, sub

W, H, D = 5.0, 2.8, 4.5            # x in [-W/2, W/2], y in [0, H], z in [-D/2, D/2]
TABLE = ((-0.7, 0.0, -1.0), (0.7, 0.74, -0.2))
SPHERE_AT, SPHERE_R = (0.25, 0.74 + 0.18, -0.6), 0.18
VASE_AT = (-0.35, 0.74, -0.55)
BOWL_AT = (-1.25, 0.0, -0.1)
POINT_AT = (0.0, 2.55, 0.0)
SPOT_AT = (2.3, 2.6, -2.05)
CAMERA_POS, CAMERA_TARGET = (0.4, 1.45, 2.0), (-0.1, 0.75, -0.8)
CAMERA_YFOV = math.radians(50.0)


def room_mesh():
    """The six inner faces of the room, facing inwards, one quad each."""
    x0, x1, y0, y1, z0, z1 = -W / 2, W / 2, 0.0, H, -D / 2, D / 2
    # corners counter-clockwise seen from inside, and the inward normal
    faces = [
        (((x0, y0, z1), (x1, y0, z1), (x1, y0, z0), (x0, y0, z0)), (0, 1, 0)),    # floor
        (((x0, y1, z0), (x1, y1, z0), (x1, y1, z1), (x0, y1, z1)), (0, -1, 0)),   # ceiling
        (((x0, y0, z0), (x1, y0, z0), (x1, y1, z0), (x0, y1, z0)), (0, 0, 1)),    # back
        (((x1, y0, z1), (x0, y0, z1), (x0, y1, z1), (x1, y1, z1)), (0, 0, -1)),   # front
        (((x0, y0, z1), (x0, y0, z0), (x0, y1, z0), (x0, y1, z1)), (1, 0, 0)),    # left
        (((x1, y0, z0), (x1, y0, z1), (x1, y1, z1), (x1, y1, z0)), (-1, 0, 0)),   # right
    ]
    meshes = []
    for corners, n in faces:
        m = Mesh()
        first = len(m.positions) // 3
        for k, p in enumerate(corners):
            m.vertex(p, n, ((k in (1, 2)) * 1.0, (k in (2, 3)) * 1.0))
        m.quad(first, first + 1, first + 2, first + 3)
        meshes.append(m)
    return meshes


def leaf_mesh():
    """A leaf-shaped fan of triangles, flat, in its node's xz plane, pointing along +x."""
    mesh = Mesh()
    n = (0.0, 1.0, 0.0)
    centre = mesh.vertex((0.09, 0.0, 0.0), n, (0.5, 0.5))
    outline = []
    for k in range(24):
        t = 2 * math.pi * k / 24
        x = 0.09 + 0.09 * math.cos(t)
        z = 0.04 * math.sin(t) * (0.35 + 0.65 * (1 - x / 0.18))
        outline.append(mesh.vertex((x, 0.0, z), n, (x / 0.18, 0.5 + z / 0.08)))
    for k in range(24):
        mesh.indices.extend((centre, outline[(k + 1) % 24], outline[k]))
    return mesh


def build(out_dir):
    b = Builder()
    b.gltf["asset"]["generator"] = "vcmfarm tests/bench/make_room.py"
    b.gltf["scenes"][0]["name"] = "Room"
    b.gltf["extensionsUsed"] = ["KHR_lights_punctual", "KHR_materials_transmission", "KHR_materials_ior"]
    m = {
        "wall": b.material(pbr("wall", base=(0.78, 0.76, 0.72, 1), roughness=1.0)),
        "ceiling": b.material(pbr("ceiling", base=(0.85, 0.85, 0.85, 1), roughness=1.0)),
        "floor": b.material(pbr("floor", base=(0.32, 0.18, 0.09, 1), roughness=0.35)),
        "table": b.material(pbr("table", base=(0.45, 0.3, 0.18, 1), roughness=0.6)),
        "gold": b.material(pbr("gold", base=(1.0, 0.77, 0.34, 1), metallic=1.0, roughness=0.2)),
        "chrome": b.material(pbr("chrome", base=(0.9, 0.9, 0.9, 1), metallic=1.0, roughness=0.05)),
        "glass": b.material(pbr("rough glass", base=(1, 1, 1, 1), roughness=0.15, extensions={
            "KHR_materials_transmission": {"transmissionFactor": 1.0}, "KHR_materials_ior": {"ior": 1.5}})),
        "leaf": b.material(pbr("leaf", base=(0.18, 0.42, 0.1, 1), roughness=0.5, doubleSided=True)),
    }
    root = b.node({"name": "Room"})
    for name, mesh in zip(("floor", "ceiling", "back wall", "front wall", "left wall", "right wall"), room_mesh()):
        material = m["floor"] if name == "floor" else m["ceiling"] if name == "ceiling" else m["wall"]
        b.node({"name": name, "mesh": b.mesh(name, mesh, material)}, root)
    b.node({"name": "Table", "mesh": b.mesh("table", box_mesh(*TABLE), m["table"])}, root)
    b.node({"name": "Gold sphere", "mesh": b.mesh("gold sphere", sphere_mesh(4000, SPHERE_R), m["gold"]),
            "translation": list(SPHERE_AT)}, root)
    # a vase: a glass shell with a wall 4 mm thick, closed at the rim
    outer = [(0.0, 0.0), (0.07, 0.0), (0.07, 0.0), (0.1, 0.08), (0.085, 0.2), (0.05, 0.3), (0.055, 0.34)]
    inner = [(0.051, 0.34), (0.046, 0.3), (0.081, 0.2), (0.096, 0.08), (0.066, 0.004), (0.0, 0.004)]
    vase = lathe_mesh(outer + [(0.055, 0.34)] + inner, 64)
    b.node({"name": "Vase", "mesh": b.mesh("vase", vase, m["glass"]), "translation": list(VASE_AT)}, root)
    bowl = lathe_mesh([(0.0, 0.0), (0.12, 0.0), (0.12, 0.0), (0.2, 0.1), (0.2, 0.1), (0.19, 0.1),
                       (0.11, 0.006), (0.0, 0.006)], 64)
    b.node({"name": "Bowl", "mesh": b.mesh("bowl", bowl, m["chrome"]), "translation": list(BOWL_AT)}, root)
    b.node({"name": "Leaf", "mesh": b.mesh("leaf", leaf_mesh(), m["leaf"]),
            "translation": [SPHERE_AT[0] + 0.2, 0.745, SPHERE_AT[2] + 0.15],
            "rotation": quat_axis_angle((1, 0, 0), 65), "scale": [1.8, 1.8, 1.8]}, root)
    point = b.light({"name": "ceiling lamp", "type": "point", "color": [1.0, 0.95, 0.88], "intensity": 9.0 * 683.0})
    b.node({"name": "Lamp", "translation": list(POINT_AT), "extensions": {"KHR_lights_punctual": {"light": point}}},
           root)
    spot = b.light({"name": "spot", "type": "spot", "color": [1.0, 0.97, 0.92], "intensity": 70.0 * 683.0,
                    "spot": {"innerConeAngle": math.radians(10), "outerConeAngle": math.radians(16)}})
    b.node({"name": "Spot", "translation": list(SPOT_AT), "rotation": quat_look(sub(SPHERE_AT, SPOT_AT)),
            "extensions": {"KHR_lights_punctual": {"light": spot}}}, root)
    b.gltf["cameras"].append({"name": "Camera", "type": "perspective", "perspective": {
        "yfov": CAMERA_YFOV, "aspectRatio": 16 / 9, "znear": 0.05, "zfar": 50.0}})
    b.node({"name": "Camera", "camera": 0, "translation": list(CAMERA_POS),
            "rotation": quat_look(sub(CAMERA_TARGET, CAMERA_POS))}, root)
    b.finish(out_dir, "room")
    return b.unique_triangles


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("out_dir", help="directory to write room.gltf and room.bin into")
    parser.add_argument("--check", action="store_true", help="verify the written files as glTF 2.0")
    args = parser.parse_args()
    os.makedirs(args.out_dir, exist_ok=True)
    triangles = build(args.out_dir)
    print("%s: %d triangles" % (os.path.join(args.out_dir, "room.gltf"), triangles))
    return report_check(os.path.join(args.out_dir, "room.gltf")) if args.check else 0


if __name__ == "__main__":
    sys.exit(main())
