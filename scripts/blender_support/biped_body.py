# SPDX-License-Identifier: GPL-3.0-or-later
"""A rig convention the shared data does not have: 3ds Max Biped's hierarchy, for
scripts/quality. In a Biped rig (Bip01 ...) the thighs hang from the first spine bone, not the
pelvis, and the clavicles from the neck, not the chest; FBX exports of Biped characters keep it.
The same body and weights with the source rig's thighs re-parented to its first spine bone and
its clavicles to its neck (bones keep their places). The source file is only read; the result
is written elsewhere.

    blender -b --factory-startup --python scripts/blender_support/biped_body.py -- SOURCE OUT

The source rig's bone names are MakeHuman's game-engine names (spine_01, neck_01, thigh_l, ...).
"""

import os
import sys

import bpy

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from rigged_body import open_rigged_body, select_only  # noqa: E402  (a sibling module, on the path just above)

NEW_PARENTS = {"thigh_l": "spine_01", "thigh_r": "spine_01", "clavicle_l": "neck_01", "clavicle_r": "neck_01"}


def main():
    source, out = sys.argv[sys.argv.index("--") + 1:][:2]
    body, armature = open_rigged_body(source, "biped_body")
    missing = [n for n in list(NEW_PARENTS) + list(NEW_PARENTS.values()) if n not in armature.data.bones]
    if missing:
        raise SystemExit(f"biped_body: the armature has no bones {sorted(set(missing))}")
    select_only(armature)
    bpy.ops.object.mode_set(mode="EDIT")
    eb = armature.data.edit_bones
    for child, parent in NEW_PARENTS.items():
        eb[child].use_connect = False
        eb[child].parent = eb[parent]
    bpy.ops.object.mode_set(mode="OBJECT")
    print("biped_body: " + ", ".join(f"{c} now under {p}" for c, p in NEW_PARENTS.items()))
    bpy.ops.wm.save_as_mainfile(filepath=out)


main()
