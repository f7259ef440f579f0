# SPDX-License-Identifier: GPL-3.0-or-later
"""The shipped MakeHuman male bent forward further than the shared instrument bends it (its
spine_bend_45), from its left, for docs/images: Armature modifier | Preserve Volume | Sweep Deform,
side by side.

    blender -b --factory-startup --python scripts/render_trunk_bend.py -- --out PNG [--zip ZIP]
            [--degrees 20] [--bones spine_01,spine_02,spine_03]

Each bone of --bones (and everything below it) is turned --degrees forward about the body's left
through its head, on top of the bones before it: 20 degrees on each of the three spine bones
is a 60 degree bend (tests/native/fit/trunk_bend_test.cpp poses the same).
"""

import os
import sys

import bpy
import numpy as np
from mathutils import Matrix, Vector

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
sys.path.insert(0, os.path.join(HERE, "blender_support"))
import demo_scene  # noqa: E402  (character loading, installation, render settings)
import flexion  # noqa: E402
import install  # noqa: E402


def parse_args():
    p = demo_scene.picture_parser("render_trunk_bend.py")
    p.add_argument("--degrees", type=float, default=20.0)
    p.add_argument("--bones", default="spine_01,spine_02,spine_03")
    p.add_argument("--no-volume", action="store_true", help="Sweep Deform without its volume preservation")
    return p.parse_args(demo_scene.script_argv())


def bend(arm, bones, degrees):
    """Turns each bone forward (about the world's +X, the body's left) through its head."""
    for name in bones:
        flexion.turn_about_head(arm, name, Matrix.Rotation(np.radians(degrees), 3, 'X'))


def main():
    args = parse_args()
    arm, body = demo_scene.load_character(os.path.abspath(args.character), "")
    install.install(args.zip)
    columns = demo_scene.deformer_copies(arm, body, "render_trunk_bend")
    b = columns[-1][1]
    b.sweep_deform.use_volume_preservation = not args.no_volume
    for a, _, _ in columns:
        bend(a, args.bones.split(","), args.degrees)

    scene = bpy.context.scene
    demo_scene.setup_render(scene, 480, 560)
    cam = demo_scene.ortho_camera(scene, "BendCamera", 0.95)
    hips = np.array(arm.matrix_world @ arm.pose.bones[args.bones.split(",")[0]].head)
    centre = Vector((hips[0], hips[1] - 0.22, hips[2] + 0.12))

    def view(shown, label):
        def place_camera():
            for _, b, _ in columns:
                b.hide_render = b is not shown
            # from the body's left, a quarter turn towards its front and a little from below
            cam.location = centre + Vector((7.07, -7.07, -1.5))
            cam.rotation_euler = (np.radians(98.5), 0.0, np.radians(45.0))
            print(f"render_trunk_bend: {label}", flush=True)
        return place_camera

    demo_scene.render_strip(scene, args.out, [view(b, label) for _, b, label in columns])
    print(f"render_trunk_bend: wrote {args.out} ({len(args.bones.split(','))} bones, "
          f"{args.degrees} degrees each)", flush=True)


if __name__ == "__main__":
    main()
