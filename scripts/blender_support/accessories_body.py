# SPDX-License-Identifier: GPL-3.0-or-later
"""A body the shared data does not have: a rigged character whose mesh carries separate parts, as
most production characters do, for scripts/quality: two eyeballs in the head (weighted to the
bone that carries the head's skin) and a close-fitting shirt, the trunk's and upper arms' skin
copied 6 mm out along the normals, a separate shell with the same weights. All in the body's one
mesh object. The instrument measures the body's largest connected part (the skin), so its figures
say whether the parts disturb the fitting and binding of the skin. The source file is only read;
the result is written elsewhere.

    blender -b --factory-startup --python scripts/blender_support/accessories_body.py -- SOURCE OUT

The source rig's bone names are MakeHuman's game-engine names (head, spine_01, upperarm_l, ...).
"""

import os
import sys

import bmesh
import bpy
from mathutils import Vector

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from rigged_body import open_rigged_body  # noqa: E402  (a sibling module, on the path just above)

SHIRT_BONES = {"pelvis", "spine_01", "spine_02", "spine_03", "clavicle_l", "clavicle_r", "upperarm_l", "upperarm_r"}
SHIRT_OFFSET = 0.006  # m
EYE_RADIUS = 0.012  # m


def heaviest_group(v, names):
    best = max(v.groups, key=lambda g: g.weight, default=None)
    return names[best.group] if best is not None else None


def main():
    source, out = sys.argv[sys.argv.index("--") + 1:][:2]
    body, armature = open_rigged_body(source, "accessories_body")
    names = {g.index: g.name for g in body.vertex_groups}
    if "head" not in body.vertex_groups:
        raise SystemExit("accessories_body: the body has no vertex group 'head'")
    mesh = body.data
    bm = bmesh.new()
    bm.from_mesh(mesh)
    deform = bm.verts.layers.deform.verify()
    bm.verts.ensure_lookup_table()
    shirt_verts = {v.index for v in mesh.vertices if heaviest_group(v, names) in SHIRT_BONES}
    faces = [f for f in bm.faces if all(v.index in shirt_verts for v in f.verts)]
    if not faces:
        raise SystemExit("accessories_body: no faces on the shirt's bones")

    # The shirt: the faces copied as a separate shell, pushed out along the vertex normals.
    copied = {}
    for f in faces:
        for v in f.verts:
            if v.index not in copied:
                nv = bm.verts.new(v.co + SHIRT_OFFSET * v.normal)
                for g, w in v[deform].items():
                    nv[deform][g] = w
                copied[v.index] = nv
    for f in faces:
        bm.faces.new([copied[v.index] for v in f.verts])

    # The eyes: spheres where the head's skin is deepest in front, a head-width apart.
    head = body.vertex_groups["head"].index
    head_pts = [v.co for v in mesh.vertices if heaviest_group(v, names) == "head"]
    lo = Vector((min(p.x for p in head_pts), min(p.y for p in head_pts), min(p.z for p in head_pts)))
    hi = Vector((max(p.x for p in head_pts), max(p.y for p in head_pts), max(p.z for p in head_pts)))
    width, front = hi.x - lo.x, lo.y  # the body faces -y
    for side in (-1.0, 1.0):
        centre = Vector(((lo.x + hi.x) / 2 + side * 0.2 * width, front + 0.03, lo.z + 0.62 * (hi.z - lo.z)))
        made = bmesh.ops.create_icosphere(bm, subdivisions=2, radius=EYE_RADIUS)
        for v in made["verts"]:
            v.co += centre
            v[deform][head] = 1.0
    bm.to_mesh(mesh)
    bm.free()
    mesh.update()
    print(f"accessories_body: {body.name} with a shirt of {len(faces)} faces and two eyes, "
          f"{len(mesh.vertices)} vertices")
    bpy.ops.wm.save_as_mainfile(filepath=out)


main()
