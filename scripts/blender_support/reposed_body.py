# SPDX-License-Identifier: GPL-3.0-or-later
"""A body the shared data does not have: a rigged character re-rested in a T-pose (the rest pose of
many production and game rigs), for scripts/quality. Both upper arms are turned, about the body's
front axis, until they point straight out sideways; the mesh is deformed there by its own Armature
modifier, and that pose becomes the armature's rest pose. The source file is only read; the
result is written elsewhere.

    blender -b --factory-startup --python scripts/blender_support/reposed_body.py -- SOURCE OUT
"""

import os
import sys

import bpy
from mathutils import Vector

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from flexion import turn_about_head  # noqa: E402  (sibling modules, on the path just above)
from rigged_body import open_rigged_body, select_only  # noqa: E402

UPPER_ARMS = ("upperarm_l", "upperarm_r")


def raise_arm(armature, name):
    bone = armature.pose.bones.get(name)
    if bone is None:
        raise SystemExit(f"reposed_body: the armature has no bone {name!r}")
    world = armature.matrix_world
    head, tail = world @ bone.head, world @ bone.tail
    now = (tail - head).normalized()
    # Straight out sideways, on the arm's own side, level.
    target = Vector((1.0 if now.x > 0.0 else -1.0, 0.0, 0.0))
    turn_about_head(armature, name, now.rotation_difference(target).to_matrix())
    print(f"reposed_body: {name} turned {now.angle(target) * 57.29578:.1f} degrees")


def main():
    source, out = sys.argv[sys.argv.index("--") + 1:][:2]
    body, armature = open_rigged_body(source, "reposed_body")
    for name in UPPER_ARMS:
        raise_arm(armature, name)

    # The mesh takes the pose (its Armature modifier applied, then put back as it was).
    mod = next(m for m in body.modifiers if m.type == "ARMATURE")
    settings = {k: getattr(mod, k) for k in ("object", "use_vertex_groups", "use_bone_envelopes",
                                             "use_deform_preserve_volume")}
    name, index = mod.name, list(body.modifiers).index(mod)
    select_only(body)
    bpy.ops.object.modifier_apply(modifier=name)

    # And the armature takes it as its rest pose.
    select_only(armature)
    bpy.ops.object.mode_set(mode="POSE")
    bpy.ops.pose.armature_apply(selected=False)
    bpy.ops.object.mode_set(mode="OBJECT")

    mod = body.modifiers.new(name, "ARMATURE")
    for k, v in settings.items():
        setattr(mod, k, v)
    bpy.context.view_layer.objects.active = body
    bpy.ops.object.modifier_move_to_index(modifier=name, index=index)
    print(f"reposed_body: {body.name} re-rested in a T-pose, {len(body.data.vertices)} vertices")
    bpy.ops.wm.save_as_mainfile(filepath=out)


main()
