# SPDX-License-Identifier: GPL-3.0-or-later
"""Time per baked frame: blend_fixtures/character.blend (75,394 vertices) bound with the core's
fitting, demo_motion baked over N frames to each target by the bake operator as scripts run
it (synchronously), next to plain playback (``scene.frame_set``) of the same frames. Prints a
table; never fails on speed.

    BLENDER_USER_RESOURCES=$(mktemp -d) scripts/blender --use 5.2 -b --factory-startup \
        --python tests/blender/measure_bake.py -- [--zip ZIP] [--frames N]
"""

import os
import sys
import tempfile
import time

import bpy

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
# install.py, flexion.py, limb_volume.py: shared with the demo and scripts/render_*.py.
sys.path.insert(0, os.path.join(os.path.dirname(os.path.dirname(HERE)), "scripts", "blender_support"))

import install  # noqa: E402


def args():
    argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
    opts = {"zip": install.default_zip(), "frames": 48}
    for i in range(0, len(argv) - 1, 2):
        opts[argv[i].lstrip("-")] = argv[i + 1]
    opts["frames"] = int(opts["frames"])
    return opts


def main():
    opts = args()
    install.install(opts["zip"])
    import helpers
    bpy.ops.wm.open_mainfile(filepath=os.path.join(helpers.FIXTURES, "character.blend"))
    obj = bpy.data.objects["Body"]
    bpy.context.view_layer.objects.active = obj
    obj.select_set(True)
    assert bpy.ops.object.sweep_deform_add() == {'FINISHED'}
    scene = bpy.context.scene
    frames = list(range(scene.frame_start, scene.frame_start + opts["frames"]))
    out = tempfile.mkdtemp(prefix="sweepdeform-bake-")
    rows = []

    t0 = time.perf_counter()
    for f in frames:
        scene.frame_set(f)
    rows.append(("playback only (frame_set)", (time.perf_counter() - t0) / len(frames)))

    for target, ext in (('SHAPE_KEYS', ""), ('PC2', ".pc2"), ('MDD', ".mdd")):
        path = os.path.join(out, "bake" + ext) if ext else ""
        t0 = time.perf_counter()
        result = bpy.ops.object.sweep_deform_bake(target=target, filepath=path, frame_start=frames[0],
                                                  frame_end=frames[-1])
        dt = time.perf_counter() - t0
        assert result == {'FINISHED'}, result
        rows.append((f"bake to {target}", dt / len(frames)))
    print(f"\nBlender {bpy.app.version_string}: {len(obj.data.vertices):,} vertices, {len(frames)} frames, "
          f"load {os.getloadavg()[0]:.1f}")
    for name, per_frame in rows:
        print(f"  {name:28s} {1000 * per_frame:7.1f} ms per frame")
    size = os.path.getsize(os.path.join(out, "bake.pc2"))
    print(f"  PC2 file: {size / 2**20:.1f} MiB ({size / len(frames) / 2**20:.2f} MiB per frame)")


main()
