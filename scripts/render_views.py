# SPDX-License-Identifier: GPL-3.0-or-later
"""One pose of the shipped MakeHuman male's left side seen from several directions, Preserve
Volume above Sweep Deform, for docs/images: the instrument (skineval) looks at each test from one
side only, and the belt around the waist and the line at the armpit showed from other sides.

    blender -b --factory-startup --python scripts/render_views.py -- --out PNG --pose POSE
            [--degrees D] [--azimuths 0,90,180,270] [--elevation 0] [--size 0.5] [--zip ZIP]

POSE: raise (the upper arm raised D degrees from hanging, in the body's frontal plane, as
skineval's shoulder_abd_*), twist (the hand turned D degrees about its bone, forearm_twist_*),
hip (thigh flexed D degrees, hip_flex_*), knee (calf flexed D degrees, knee_flex_*), elbow
(forearm flexed D degrees, elbow_flex_*), neck (the neck turned D degrees about the line from its
base to the head's joint, neck_twist_*). Azimuths in degrees about the joint, 0 from the front,
90 from the body's left; the elevation looks from above (positive) or below; --size is each
view's orthographic width in metres. Rows: Preserve Volume, Sweep Deform; a column per azimuth.
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
import render_shoulder_raise  # noqa: E402  (raise_arm)

#: pose -> (the joint's bone the views look at, default degrees)
POSES = {"raise": ("upperarm_l", 160.0), "twist": ("lowerarm_l", 180.0), "hip": ("thigh_l", 90.0),
         "knee": ("calf_l", 135.0), "elbow": ("lowerarm_l", 120.0), "neck": ("neck_01", 60.0)}


def parse_args():
    p = demo_scene.picture_parser("render_views.py")
    p.add_argument("--pose", choices=sorted(POSES), required=True)
    p.add_argument("--degrees", type=float)
    p.add_argument("--azimuths", default="0,90,180,270")
    p.add_argument("--elevation", type=float, default=0.0)
    p.add_argument("--size", type=float, default=0.5)
    return p.parse_args(demo_scene.script_argv())


def pose(arm, name, degrees):
    """Poses `arm` (at rest) as `name` by `degrees`."""
    if name == "raise":
        render_shoulder_raise.raise_arm(arm, "upperarm_l", degrees)
    elif name == "neck":
        world = arm.matrix_world
        along = ((world @ arm.pose.bones["head"].head) - (world @ arm.pose.bones["neck_01"].head)).normalized()
        flexion.turn_about_head(arm, "neck_01", Matrix.Rotation(np.radians(degrees), 3, along))
    elif name == "twist":
        pb, world = arm.pose.bones["hand_l"], arm.matrix_world
        along = ((world @ pb.tail) - (world @ pb.head)).normalized()
        flexion.turn_about_head(arm, "hand_l", Matrix.Rotation(np.radians(degrees), 3, along))
    else:  # a flexion towards the body's front (hip, elbow) or back (knee); characters face -Y
        lower = {"hip": "thigh_l", "knee": "calf_l", "elbow": "lowerarm_l"}[name]
        flexion.flex(arm, lower, (0.0, 1.0, 0.0) if name == "knee" else (0.0, -1.0, 0.0), degrees)


def main():
    args = parse_args()
    joint, default = POSES[args.pose]
    degrees = default if args.degrees is None else args.degrees
    arm, body = demo_scene.load_character(os.path.abspath(args.character), "")
    install.install(args.zip)
    every = demo_scene.deformer_copies(arm, body, "render_views")
    columns = [c for c in every if c[2] != "Armature"]
    for a, _, _ in columns:
        pose(a, args.pose, degrees)

    scene = bpy.context.scene
    demo_scene.setup_render(scene, 400, 400)
    cam = demo_scene.ortho_camera(scene, "ViewsCamera", args.size)
    elevation = np.radians(args.elevation)

    def view(a, shown, azimuth):
        def place_camera():
            for _, b, _ in every:
                b.hide_render = b is not shown
            centre = a.matrix_world @ a.pose.bones[joint].head
            r = np.radians(azimuth)
            cam.location = centre + 10.0 * Vector((np.sin(r) * np.cos(elevation), -np.cos(r) * np.cos(elevation),
                                                   np.sin(elevation)))
            cam.rotation_euler = (np.pi / 2 - elevation, 0.0, r)
        return place_camera

    azimuths = [float(x) for x in args.azimuths.split(",")]
    views = [view(a, b, az) for a, b, _ in columns for az in azimuths]
    demo_scene.render_strip(scene, args.out, views, per_row=len(azimuths))
    print(f"render_views: wrote {args.out} ({args.pose} {degrees:g} degrees; rows "
          f"{', '.join(label for _, _, label in columns)}; azimuths {args.azimuths})", flush=True)


if __name__ == "__main__":
    main()
