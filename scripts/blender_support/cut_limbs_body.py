# SPDX-License-Identifier: GPL-3.0-or-later
"""A rig convention the shared data does not have: each upper arm, forearm, thigh and shin cut
in two chained bones, as Rigify's deform bones (DEF-upper_arm.L, DEF-upper_arm.L.001), DAZ's bend
and twist bones and MakeHuman's default rig (lowerarm01.L, lowerarm02.L) cut them, for
scripts/quality. The first half keeps the bone's name, the second is NAME.001 and takes its
children; a vertex's weight on the bone passes to the second half along it (smoothstep over its
middle half). The source file is only read; the result is written elsewhere.

    blender -b --factory-startup --python scripts/blender_support/cut_limbs_body.py -- SOURCE OUT
"""

import os
import sys

import bpy

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from rigged_body import open_rigged_body, pass_weight, select_only, smoothstep  # noqa: E402  (a sibling module)

LIMB_BONES = [f"{bone}_{side}" for side in ("l", "r") for bone in ("upperarm", "lowerarm", "thigh", "calf")]


def cut_in_two(body, armature, names):
    """Cuts each bone of `names` into two chained halves (Blender's Subdivide; the second half is
    NAME.001 and takes the bone's children) and passes a vertex's weight on it to the second half
    along the bone (smoothstep over its middle half). Leaves Object Mode active."""
    missing = [n for n in names if n not in armature.data.bones or n not in body.vertex_groups]
    if missing:
        raise ValueError(f"no bone or vertex group {missing}")
    ends = {n: (armature.data.bones[n].head_local.copy(), armature.data.bones[n].tail_local.copy()) for n in names}
    select_only(armature)
    bpy.ops.object.mode_set(mode="EDIT")
    for eb in armature.data.edit_bones:
        eb.select = eb.select_head = eb.select_tail = eb.name in names
    bpy.ops.armature.subdivide(number_cuts=1)
    bpy.ops.object.mode_set(mode="OBJECT")
    for name in names:
        head, tail = ends[name]
        pass_weight(body, armature, name, body.vertex_groups.new(name=name + ".001"), head, tail,
                    lambda along: smoothstep((along - 0.25) / 0.5))


def main():
    source, out = sys.argv[sys.argv.index("--") + 1:][:2]
    body, armature = open_rigged_body(source, "cut_limbs_body")
    try:
        cut_in_two(body, armature, LIMB_BONES)
    except ValueError as e:
        raise SystemExit(f"cut_limbs_body: {e}")
    print(f"cut_limbs_body: {len(LIMB_BONES)} bones cut in two "
          f"({', '.join(n + '.001' for n in LIMB_BONES if n + '.001' in armature.data.bones)})")
    bpy.ops.wm.save_as_mainfile(filepath=out)


if __name__ == "__main__":
    main()
