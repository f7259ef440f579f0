# SPDX-License-Identifier: GPL-3.0-or-later
"""A body the shared data does not have: a game level of detail of a rigged character, made by
Blender's own Decimate modifier (collapse, which carries the vertex groups along), for
scripts/quality. The source file is only read; the result is written elsewhere.

    blender -b --factory-startup --python scripts/blender_support/decimated_body.py -- SOURCE RATIO OUT
"""

import sys

import bpy


def main():
    source, ratio, out = sys.argv[sys.argv.index("--") + 1:][:3]
    bpy.ops.wm.open_mainfile(filepath=source)
    bodies = [o for o in bpy.data.objects if o.type == "MESH" and o.find_armature()]
    if len(bodies) != 1:
        raise SystemExit(f"decimated_body: {source} has {len(bodies)} rigged meshes, expected one")
    body = bodies[0]
    bpy.context.view_layer.objects.active = body
    for o in bpy.context.view_layer.objects:
        o.select_set(o == body)
    before = len(body.data.vertices)
    mod = body.modifiers.new("LOD", "DECIMATE")
    mod.ratio = float(ratio)
    bpy.ops.object.modifier_move_to_index(modifier=mod.name, index=0)
    bpy.ops.object.modifier_apply(modifier=mod.name)
    print(f"decimated_body: {body.name} {before} -> {len(body.data.vertices)} vertices")
    bpy.ops.wm.save_as_mainfile(filepath=out)


main()
