# SPDX-License-Identifier: GPL-3.0-or-later
"""A body the shared data does not have: a rigged character made broader or slimmer, for
scripts/quality. Mesh and armature are scaled together about the point between the feet, by
WIDTH across and front to back and HEIGHT up, and the scale is applied to both, so the rig's
bones keep their place in the body (a broad body has thick limbs on the same skeleton's
proportions; nothing new touches at rest, the gaps between arm and trunk grow with the rest).
The source file is only read; the result is written elsewhere.

    blender -b --factory-startup --python scripts/blender_support/proportioned_body.py -- \
        SOURCE WIDTH HEIGHT OUT
"""

import os
import sys

import bpy
from mathutils import Matrix, Vector

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from rigged_body import open_rigged_body, select_only  # noqa: E402  (a sibling module, on the path just above)


def main():
    source, width, height, out = sys.argv[sys.argv.index("--") + 1:][:4]
    width, height = float(width), float(height)
    if not (0.2 <= width <= 5.0 and 0.2 <= height <= 5.0):
        raise SystemExit(f"proportioned_body: WIDTH and HEIGHT must lie in [0.2, 5], got {width} {height}")
    body, armature = open_rigged_body(source, "proportioned_body")
    depsgraph = bpy.context.evaluated_depsgraph_get()
    before = [body.matrix_world @ v.co for v in body.evaluated_get(depsgraph).data.vertices]
    # The body's up is the world's Z in the files we read (Blender's convention); the centre
    # between the feet is the lowest point's height under the bounding box's middle.
    lowest = min(p.z for p in before)
    middle = sum((p for p in before), Vector()) / len(before)
    centre = Vector((middle.x, middle.y, lowest))
    scale = Matrix.Diagonal((width, width, height, 1.0))
    about = Matrix.Translation(centre) @ scale @ Matrix.Translation(-centre)

    worlds = {o: o.matrix_world.copy() for o in (armature, body)}
    for o, m in worlds.items():
        o.matrix_world = about @ m
    bpy.context.view_layer.update()
    select_only(armature, body)
    bpy.ops.object.transform_apply(location=False, rotation=False, scale=True)
    bpy.context.view_layer.update()

    # The applied body must be the scaled one, vertex for vertex (rest pose).
    depsgraph = bpy.context.evaluated_depsgraph_get()
    after = [body.matrix_world @ v.co for v in body.evaluated_get(depsgraph).data.vertices]
    worst = max((a - about @ b).length for a, b in zip(after, before))
    if worst > 1e-4:
        raise SystemExit(f"proportioned_body: the applied body is {worst:.2e} m from the scaled one")
    print(f"proportioned_body: {body.name} scaled {width} across, {height} up "
          f"({len(after)} vertices, {worst:.1e} m from the scaled source)")
    bpy.ops.wm.save_as_mainfile(filepath=out)


main()
