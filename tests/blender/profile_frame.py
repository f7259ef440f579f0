# SPDX-License-Identifier: GPL-3.0-or-later
"""Where one frame of Sweep Deform goes, inside Blender: cProfile around the pose changes of
measure_frame.py's posing loop (the product's set-up: the fitted rig, the replaced Armature
modifier switched off but keeping its object), and the add-on's handler alone. Prints the
profile, then the median time of each part of the handler timed alone (no profiler's overhead:
the core's call (with the output check and the offsets' sums: one pass), the carrier's write); never
fails on speed.

    BLENDER_USER_RESOURCES=$(mktemp -d) scripts/blender --use 5.2 -b --factory-startup \\
        --python tests/blender/profile_frame.py -- [--zip ZIP] [--frames N] [--shape-key 1|head] [--characters NAME]
"""

import cProfile
import collections
import io
import os
import pstats
import sys
import time

import bpy
import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
sys.path.insert(0, os.path.join(os.path.dirname(os.path.dirname(HERE)), "scripts", "blender_support"))

import install  # noqa: E402
import measure_frame  # noqa: E402


def main():
    opts = measure_frame.args()
    install.install(opts["zip"])
    body, arm, _, bones = measure_frame.load(opts["characters"].split(",")[0] if "--characters" in sys.argv else "fixture")
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
    print_parts(body, arm, pose_list[5:])


def print_parts(body, arm, pose_list):
    """Median ms of each part of the handler over the pose changes, each part timed alone."""
    from bl_ext.user_default.sweep_deform.blender import frame, handlers, modifier, shape_keys
    from bl_ext.user_default.sweep_deform.core import arrays, native
    spent = collections.defaultdict(list)
    parts = [
        (handlers, "evaluate_scene", "handler"),
        (frame, "_evaluate_entry", "the object's frame"),
        (native.Deformer, "deform", "core: sd_deform"),
        (native.Deformer, "deform_displaced", "core: sd_deform_displaced"),
        (native.Deformer, "deform_frame", "core: sd_deform_frame (and check and sums)"),
        (frame, "_checked_output", "output check"),
        (native, "compose_offsets", "offsets (and the keys' J d), one pass"),
        (arrays, "offsets_into", "offsets"),
        (shape_keys, "displacements", "keys' displacements"),
        (arrays, "add_to_rows", "keys' scatter"),
        (modifier, "write_offsets", "carrier write"),
    ]
    originals = []
    for owner, name, label in parts:
        f = getattr(owner, name)
        originals.append((owner, name, f))

        def timed(*a, _f=f, _label=label, **k):
            t = time.perf_counter()
            try:
                return _f(*a, **k)
            finally:
                spent[_label].append(time.perf_counter() - t)
        setattr(owner, name, timed)
    try:
        posing = measure_frame.time_posing(body, arm, pose_list)
    finally:
        for owner, name, f in originals:
            setattr(owner, name, f)
    print(f"\n==== {len(pose_list)} pose changes, each part alone (median ms) ====")
    print(f"  {'pose change, evaluated':44s} {1e3 * np.median(posing):.3f}")
    for _, _, label in parts:
        if spent[label]:
            print(f"  {label:44s} {1e3 * np.median(spent[label]):.3f}  ({len(spent[label])} calls)")


if __name__ == "__main__":
    main()
