"""Runs the shared instrument (../shared/skineval/measure.py) in Blender 5.x, whose actions have no
`Action.fcurves` any more (slotted actions, removed in 5.0): the instrument's `set_test_action`
stopped at "'Action' object has no attribute 'fcurves'" on every test. This replaces only that
function, creating the same keyframes (odd frames rest, even frames the test pose, linear) through
`Action.fcurve_ensure_for_datablock` (Blender 4.4+); every measurement stays the instrument's.
In Blender 4.x the instrument runs unchanged.

  blender -b --python scripts/skineval_compat.py -- <measure.py's arguments>
"""
import os
import sys

import bpy
import numpy as np

SKINEVAL = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "..", "shared", "skineval")
sys.path.insert(0, os.path.normpath(os.environ.get("SKINEVAL_DIR", SKINEVAL)))

from hlib import bl  # noqa: E402  (the instrument's own module)
import measure  # noqa: E402


def set_test_action(arm, quats, nframes):
    """The instrument's set_test_action, with F-curves made for the armature's slot."""
    if arm.animation_data is None:
        arm.animation_data_create()
    for pb in arm.pose.bones:
        pb.rotation_quaternion = (1, 0, 0, 0)
    old = arm.animation_data.action
    act = bpy.data.actions.new("harness_test")
    arm.animation_data.action = act
    if old is not None and old.users == 0:
        bpy.data.actions.remove(old)
    frames = np.arange(1, nframes + 1, dtype=np.float64)
    ident = (1.0, 0.0, 0.0, 0.0)
    for bname, q in quats.items():
        path = 'pose.bones["%s"].rotation_quaternion' % bpy.utils.escape_identifier(bname)
        for i in range(4):
            fc = act.fcurve_ensure_for_datablock(arm, path, index=i, group_name=bname)
            fc.keyframe_points.add(nframes)
            vals = np.where(frames % 2 == 1, ident[i], q[i])
            co = np.empty(2 * nframes)
            co[0::2] = frames
            co[1::2] = vals
            fc.keyframe_points.foreach_set("co", co)
            for kp in fc.keyframe_points:
                kp.interpolation = "LINEAR"
            fc.update()
    return act


if "fcurves" not in bpy.types.Action.bl_rna.properties:  # RNA, not a Python attribute of the class
    bl.set_test_action = set_test_action
measure.main()
