# SPDX-License-Identifier: GPL-3.0-or-later
"""Where one frame of Sweep Deform goes, inside Blender: cProfile around the pose changes of
measure_frame.py's posing loop (the product's set-up: the fitted rig, the replaced Armature
modifier switched off but keeping its object), and the add-on's handler alone. Prints the
profile; never fails on speed.

    BLENDER_USER_RESOURCES=$(mktemp -d) scripts/blender --use 5.2 -b --factory-startup \\
        --python tests/blender/profile_frame.py -- [--zip ZIP] [--frames N] [--shape-key 1|head]
"""

import cProfile
import io
import os
import pstats
import sys

import bpy

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
sys.path.insert(0, os.path.join(os.path.dirname(os.path.dirname(HERE)), "scripts", "blender_support"))

import install  # noqa: E402
import measure_frame  # noqa: E402


def main():
    opts = measure_frame.args()
    install.install(opts["zip"])
    body, arm, _, bones = measure_frame.load("fixture")
    bpy.context.view_layer.objects.active = body
    assert bpy.ops.object.sweep_deform_add() == {'FINISHED'}
    if opts["shape-key"]:
        measure_frame.add_shape_key(body, opts["shape-key"])
    n = opts["frames"]
    pose_list = measure_frame.poses(n + 5, bones)
    measure_frame.time_posing(body, arm, pose_list[:5])  # warm: the check, the carriers, the buffers
    for label, sort in (("whole update (view_layer.update)", "cumulative"), ("by own time", "tottime")):
        profile = cProfile.Profile()
        profile.enable()
        measure_frame.time_posing(body, arm, pose_list[5:])
        profile.disable()
        out = io.StringIO()
        pstats.Stats(profile, stream=out).sort_stats(sort).print_stats(25)
        print(f"\n==== {n} pose changes, {label} ====\n{out.getvalue()}")


if __name__ == "__main__":
    main()
