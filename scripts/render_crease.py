# SPDX-License-Identifier: GPL-3.0-or-later
"""Close-ups of the built-in character's left elbow at exactly 150° of flexion with Sweep
Deform's anatomical effects (the folded crease), for docs/images:

    blender -b --factory-startup --python scripts/render_crease.py -- --out PNG [--zip ZIP]
            [--character FILE.blend] [--degrees 150]

Binds with the automatic fitting (bpy.ops.object.sweep_deform_add), turns the effects on, poses
the elbow with scripts/blender_support/flexion.py and renders (Workbench) two views side by side: from the
character's left (+X, as the demo's close-ups) and from the front, slightly from below.
"""

import os
import sys

import bpy
import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
sys.path.insert(0, os.path.join(HERE, "blender_support"))
import demo_scene  # noqa: E402  (character loading, installation, render settings)
import flexion  # noqa: E402
import install  # noqa: E402


def parse_args():
    p = demo_scene.picture_parser("render_crease.py")
    p.set_defaults(character=os.path.join(demo_scene.REPO, "blend_fixtures", "character.blend"))
    p.add_argument("--degrees", type=float, default=150.0)
    p.add_argument("--size", type=float, default=0.26, help="ortho scale of each view (m)")
    return p.parse_args(demo_scene.script_argv())


def main():
    args = parse_args()
    arm, body = demo_scene.load_character(os.path.abspath(args.character), "")
    install.install(args.zip)
    arm.animation_data.action = None
    demo_scene.bind(arm, body, "render_crease")
    s = body.sweep_deform
    s.use_anatomy = True
    joint = next(j for j in s.joints if j.kind == 'ELBOW' and j.name.endswith("L"))
    angle = flexion.flex(arm, joint.bone, joint.flexion_direction, args.degrees)
    print(f"render_crease: {joint.bone} at {angle:.2f} degrees", flush=True)

    scene = bpy.context.scene
    demo_scene.setup_render(scene, 520, 520)
    cam = demo_scene.ortho_camera(scene, "CreaseCamera", args.size)
    pb = arm.pose.bones[joint.bone]
    where = np.array(arm.matrix_world @ pb.head)
    views = [((where[0] + 10.0, where[1], where[2]), (np.pi / 2, 0.0, np.pi / 2)),           # from +X
             ((where[0], where[1] - 10.0, where[2] - 3.0), (np.radians(106.7), 0.0, 0.0))]   # front, below

    def place(loc, rot):
        def place_camera():
            cam.location, cam.rotation_euler = loc, rot
        return place_camera

    demo_scene.render_strip(scene, args.out, [place(loc, rot) for loc, rot in views])
    print(f"render_crease: wrote {args.out}", flush=True)


if __name__ == "__main__":
    main()
