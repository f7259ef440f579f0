# SPDX-License-Identifier: GPL-3.0-or-later
"""Renders a character's fitted key ellipses over its mesh (docs pictures for the fitting).

    blender -b --factory-startup --python scripts/render_fit.py -- --character FILE --out PNG

Loads the character like the demo does, installs the extension, binds with
bpy.ops.object.sweep_deform_add() (the automatic fitting), and draws every key ellipse of the
fitting report as a thin tube over a see-through mesh, front and side views side by side.
"""

import argparse
import json
import os
import sys

import bpy
import numpy as np
from mathutils import Vector

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import demo_scene  # noqa: E402  (character loading, installation, camera, render)


def ellipse_object(key, to_world, radius):
    """A closed poly curve through the key ellipse, as a thin tube."""
    c, n, u = (Vector(key[k]) for k in ("center", "normal", "first_axis"))
    v = n.cross(u)
    a, b = key["half_axes"]
    curve = bpy.data.curves.new("key", 'CURVE')
    curve.dimensions = '3D'
    curve.bevel_depth = radius
    spline = curve.splines.new('POLY')
    spline.points.add(47)
    for i, p in enumerate(spline.points):
        t = 2 * np.pi * i / 48
        q = to_world @ (c + float(a * np.cos(t)) * u + float(b * np.sin(t)) * v)
        p.co = (q.x, q.y, q.z, 1.0)
    spline.use_cyclic_u = True
    obj = bpy.data.objects.new("key", curve)
    bpy.context.scene.collection.objects.link(obj)
    return obj


def main():
    p = argparse.ArgumentParser(prog="render_fit.py")
    p.add_argument("--character", required=True)
    p.add_argument("--out", required=True)
    p.add_argument("--zip", default=demo_scene.install.default_zip())
    args = p.parse_args(demo_scene.script_argv())
    arm, body = demo_scene.load_character(os.path.abspath(args.character), "")
    demo_scene.install.install(args.zip)
    scene = bpy.context.scene
    demo_scene.put_at_rest(arm)
    demo_scene.bind(arm, body, "render_fit")
    report = json.loads(body.get("_sweep_deform_fit_report", "{}"))
    lo, hi = demo_scene.world_bbox([body])
    height = float(hi[2] - lo[2])
    count = 0
    for chain in report.get("chains", []):
        for key in chain.get("keys", []):
            ellipse_object(key, arm.matrix_world, 0.004 * height)
            count += 1
    demo_scene.setup_render(scene, 900, 900)
    scene.display.shading.show_xray = True
    scene.display.shading.xray_alpha = 0.35
    scene.display.shading.color_type = 'OBJECT'
    body.color = (0.8, 0.65, 0.55, 1.0)
    for o in scene.objects:
        if o.type == 'CURVE':
            o.color = (0.05, 0.45, 0.95, 1.0)

    def place(view, rot):
        def place_camera():
            cam = demo_scene.front_camera(scene, lo - 0.02 * height, hi + 0.02 * height)
            if view == "side":
                center = (lo + hi) / 2
                cam.location = (hi[0] + 10.0, center[1], center[2])
                cam.data.ortho_scale = 1.08 * max(hi[1] - lo[1], hi[2] - lo[2])
            cam.rotation_euler = rot
        return place_camera

    demo_scene.render_strip(scene, args.out, [place("front", (np.pi / 2, 0.0, 0.0)),
                                              place("side", (np.pi / 2, 0.0, np.pi / 2))])
    print(f"render_fit: {count} key ellipses of {len(report.get('chains', []))} chains -> {args.out}", flush=True)


if __name__ == "__main__":
    main()
