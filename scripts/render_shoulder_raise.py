# SPDX-License-Identifier: GPL-3.0-or-later
"""The top of the left shoulder of a character whose left arm is raised in the body's frontal
plane, as the shared instrument raises it (its shoulder_abd_160), seen from the front, for
docs/images: Armature modifier | Preserve Volume | Sweep Deform, side by side.

    blender -b --factory-startup --python scripts/render_shoulder_raise.py -- --out PNG [--zip ZIP]
            [--character FILE.blend] [--degrees 160] [--arm upperarm_l] [--size 0.3]

The upper arm (and everything below it) is turned about the body's front through its head until
it points --degrees from the body's down (+Z up, -Y front, as the MakeHuman males are).
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
    p = demo_scene.picture_parser("render_shoulder_raise.py")
    p.add_argument("--degrees", type=float, default=160.0)
    p.add_argument("--arm", default="upperarm_l")
    p.add_argument("--size", type=float, default=0.3, help="ortho scale of each view (m)")
    return p.parse_args(demo_scene.script_argv())


def raise_arm(arm, name, degrees):
    """Turns the upper arm about the body's front until it points `degrees` from the body's
    down, in the plane of the down and the arm's side (world space)."""
    pb = arm.pose.bones[name]
    world = arm.matrix_world
    d = ((world @ pb.tail) - (world @ pb.head)).normalized()
    down, side = Vector((0.0, 0.0, -1.0)), Vector((1.0 if d.x >= 0.0 else -1.0, 0.0, 0.0))
    rest = np.degrees(np.arctan2(d.dot(side), d.dot(down)))
    axis = down.cross(side).normalized()  # turns the down towards the side
    flexion.turn_about_head(arm, name, Matrix.Rotation(np.radians(degrees - rest), 3, axis))


def main():
    args = parse_args()
    arm, body = demo_scene.load_character(os.path.abspath(args.character), "")
    install.install(args.zip)
    columns = demo_scene.deformer_copies(arm, body, "render_shoulder_raise")
    for a, _, _ in columns:
        raise_arm(a, args.arm, args.degrees)

    scene = bpy.context.scene
    demo_scene.setup_render(scene, 500, 500)
    cam = demo_scene.ortho_camera(scene, "ShoulderCamera", args.size)

    def view(a, shown, label):
        def place_camera():
            for _, b, _ in columns:
                b.hide_render = b is not shown
            head = a.matrix_world @ a.pose.bones[args.arm].head
            cam.location = head + Vector((0.0, -5.0, 0.04))
            cam.rotation_euler = (np.radians(90.0), 0.0, 0.0)  # looking along +Y: the body's front
            print(f"render_shoulder_raise: {label}", flush=True)
        return place_camera

    demo_scene.render_strip(scene, args.out, [view(a, b, label) for a, b, label in columns])
    print(f"render_shoulder_raise: wrote {args.out} ({args.arm} at {args.degrees} degrees)", flush=True)


if __name__ == "__main__":
    main()
