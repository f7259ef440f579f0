# SPDX-License-Identifier: GPL-3.0-or-later
"""Renders: F12 (bpy.ops.render.render) and `blender -b file.blend -a` show the pose of the
frame being rendered (Workbench, tiny images)."""

import os
import subprocess

import bpy
import numpy as np
from mathutils import Vector

import helpers

RAISED = (0.0, 0.0, 1.1)  # the upper arm turned about its local Z: the arm leaves its silhouette


def setup_scene(char):
    scene = bpy.context.scene
    scene.render.engine = 'BLENDER_WORKBENCH'
    scene.render.resolution_x, scene.render.resolution_y = 48, 64
    scene.render.resolution_percentage = 100
    scene.render.image_settings.file_format = 'PNG'
    scene.render.image_settings.color_mode = 'RGB'
    scene.display.shading.light = 'FLAT'
    scene.display.shading.color_type = 'SINGLE'
    cam = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
    scene.collection.objects.link(cam)
    scene.camera = cam
    obj = char.mesh
    corners = [obj.matrix_world @ Vector(c) for c in obj.bound_box]
    lo = Vector([min(c[i] for c in corners) for i in range(3)])
    hi = Vector([max(c[i] for c in corners) for i in range(3)])
    center, size = (lo + hi) / 2, max((hi - lo)[i] for i in range(3))
    cam.data.type = 'ORTHO'
    cam.data.ortho_scale = 1.6 * size
    cam.location = center + Vector((0.0, -10.0 * size, 0.0))
    cam.rotation_euler = (np.pi / 2, 0.0, 0.0)
    cam.data.clip_end = 100.0 * size


def key_alternating_poses(char, frames=(1, 2, 3, 4)):
    """Frames 1, 3: rest; 2, 4: arms raised (constant keys, no interpolation)."""
    prefs = bpy.context.preferences.edit
    saved = prefs.keyframe_new_interpolation_type
    prefs.keyframe_new_interpolation_type = 'CONSTANT'
    try:
        arm = char.armature
        for f in frames:
            for n in char.shoulders:
                helpers.set_rotation(arm.pose.bones[n], RAISED if f % 2 == 0 else (0.0, 0.0, 0.0))
                arm.pose.bones[n].keyframe_insert("rotation_euler", frame=f)
    finally:
        prefs.keyframe_new_interpolation_type = saved
    scene = bpy.context.scene
    scene.frame_start, scene.frame_end = frames[0], frames[-1]


def read_png(path):
    img = bpy.data.images.load(path, check_existing=False)
    try:
        px = np.empty(len(img.pixels), np.float32)
        img.pixels.foreach_get(px)
        return px.reshape(img.size[1], img.size[0], -1)[..., :3]
    finally:
        bpy.data.images.remove(img)


def render_still(path):
    bpy.context.scene.render.filepath = path
    assert bpy.ops.render.render(write_still=True) == {'FINISHED'}
    return read_png(path)


def differing(a, b):
    return int((np.abs(a - b).max(axis=2) > 0.02).sum())


def test_f12_and_animation_render_the_pose_of_each_frame():
    char = helpers.load("makehuman")
    helpers.use_test_rig([char])
    obj = helpers.bind(char)
    setup_scene(char)
    key_alternating_poses(char)
    scene = bpy.context.scene
    out = helpers.tmp_dir()

    # F12 on frames 2 and 1, in that order (a stale pose would show the other frame's).
    scene.frame_set(2)
    raised = render_still(os.path.join(out, "still_2.png"))
    scene.frame_set(1)
    rest = render_still(os.path.join(out, "still_1.png"))
    # The same frame with Blender's Armature modifier instead: nearly the same picture.
    md_sweep = helpers.sub("blender.modifier").find(obj)
    md_arm = obj.modifiers[obj.sweep_deform.armature_modifier]
    md_sweep.show_render, md_arm.show_render, md_arm.object = False, True, obj.sweep_deform.armature
    scene.frame_set(2)
    lbs = render_still(os.path.join(out, "still_2_armature.png"))
    md_sweep.show_render, md_arm.show_render = True, False
    pose_change, vs_lbs = differing(rest, raised), differing(raised, lbs)
    print(f"F12: {pose_change} pixels change with the pose, {vs_lbs} differ from the Armature modifier's")
    assert pose_change > 40
    assert vs_lbs < pose_change / 4

    # `blender -b file.blend -a` in a fresh Blender: the add-on comes from the installed
    # user preferences, the binding from the file; frames render in the order 1, 2, 3, 4.
    scene.render.filepath = os.path.join(out, "anim_####")
    scene.frame_set(1)
    path = os.path.join(out, "render_anim.blend")
    bpy.ops.wm.save_as_mainfile(filepath=path)
    for f in range(1, 5):
        p = os.path.join(out, f"anim_{f:04d}.png")
        if os.path.exists(p):
            os.remove(p)
    proc = subprocess.run([bpy.app.binary_path, "-b", path, "-a"], capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stdout[-2000:] + proc.stderr[-2000:]
    frames = [read_png(os.path.join(out, f"anim_{f:04d}.png")) for f in range(1, 5)]
    print("-a: frame differences", [differing(frames[0], f) for f in frames])
    assert differing(frames[0], frames[2]) == 0 and differing(frames[1], frames[3]) == 0
    assert differing(frames[0], frames[1]) == pose_change
    assert differing(frames[0], rest) == 0 and differing(frames[1], raised) == 0
