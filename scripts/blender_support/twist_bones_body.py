# SPDX-License-Identifier: GPL-3.0-or-later
"""A rig convention the shared data does not have: twist bones hung beside the limb bones, as
Unreal's mannequin has them (upperarm_twist_01_l, lowerarm_twist_01_l, thigh_twist_01_l,
calf_twist_01_l), for scripts/quality. Each is a child of its limb bone over the bone's upper
half (upper arm, thigh) or lower half (forearm, shin), and takes up to half of the bone's skin
weight there (smoothstep from the bone's middle). The source file is only read; the result is
written elsewhere.

    blender -b --factory-startup --python scripts/blender_support/twist_bones_body.py -- SOURCE OUT
"""

import os
import sys

import bpy

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from rigged_body import open_rigged_body, pass_weight, select_only, smoothstep  # noqa: E402  (a sibling module)

# (limb bone, over its lower half?) per side
LIMBS = [(f"{bone}_{side}", lower) for side in ("l", "r")
         for bone, lower in (("upperarm", False), ("lowerarm", True), ("thigh", False), ("calf", True))]


def twist_name(bone):
    name, side = bone.rsplit("_", 1)
    return f"{name}_twist_01_{side}"


def add_twist_bones(body, armature):
    missing = [n for n, _ in LIMBS if n not in armature.data.bones or n not in body.vertex_groups]
    if missing:
        raise ValueError(f"no bone or vertex group {missing}")
    ends = {n: (armature.data.bones[n].head_local.copy(), armature.data.bones[n].tail_local.copy()) for n, _ in LIMBS}
    select_only(armature)
    bpy.ops.object.mode_set(mode="EDIT")
    for name, lower in LIMBS:
        head, tail = ends[name]
        mid = (head + tail) * 0.5
        eb = armature.data.edit_bones.new(twist_name(name))
        eb.head, eb.tail = (mid, tail) if lower else (head, mid)
        eb.roll = armature.data.edit_bones[name].roll
        eb.parent = armature.data.edit_bones[name]
    bpy.ops.object.mode_set(mode="OBJECT")
    for name, lower in LIMBS:
        head, tail = ends[name]
        pass_weight(body, armature, name, body.vertex_groups.new(name=twist_name(name)), head, tail,
                    (lambda along: 0.5 * smoothstep((along - 0.4) / 0.4)) if lower else
                    (lambda along: 0.5 * smoothstep((0.6 - along) / 0.4)))


def main():
    source, out = sys.argv[sys.argv.index("--") + 1:][:2]
    body, armature = open_rigged_body(source, "twist_bones_body")
    try:
        add_twist_bones(body, armature)
    except ValueError as e:
        raise SystemExit(f"twist_bones_body: {e}")
    print(f"twist_bones_body: {len(LIMBS)} twist bones ({', '.join(twist_name(n) for n, _ in LIMBS)})")
    bpy.ops.wm.save_as_mainfile(filepath=out)


if __name__ == "__main__":
    main()
