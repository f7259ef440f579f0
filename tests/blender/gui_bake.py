# SPDX-License-Identifier: GPL-3.0-or-later
"""Run by test_bake.py in a GUI Blender under Xvfb (modal operators need a window):

    blender --factory-startup --enable-event-simulate character_light.blend \\
        --python gui_bake.py -- OUT_DIR

1. binds the character (test rig), then bakes frames 70–75 to OUT_DIR/gui.pc2 as the
   interface does (INVOKE_DEFAULT with a path: no file browser, modal at once);
2. bakes the whole timeline to an MDD and presses Esc once three frames are in the partial file;
3. bakes the whole timeline to shape keys as the interface does after its dialog
   (``run_modal``) and presses Esc once three keys exist;
4. prints ``RESULT {json}``: what the operators returned, what was left in OUT_DIR, the
   objects, meshes, the character's modifier stack and the current frame.
"""

import os
import sys

import bpy

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
OUT = sys.argv[sys.argv.index("--") + 1]

bpy.ops.preferences.addon_enable(module="bl_ext.user_default.sweep_deform")

import helpers  # noqa: E402
from gui_support import finish, guarded, result  # noqa: E402


def window():
    return bpy.context.window_manager.windows[0]


def press_esc():
    window().event_simulate(type='ESC', value='PRESS')
    window().event_simulate(type='ESC', value='RELEASE')


@guarded
def start():
    char = helpers.Character("fixture", "Body", "Armature", [], [], helpers.bone_rig.FIXTURE_CHAINS)
    helpers.use_test_rig([char])
    with bpy.context.temp_override(window=window()):
        bpy.context.view_layer.objects.active = char.mesh
        result["bind"] = list(bpy.ops.object.sweep_deform_add('EXEC_DEFAULT'))
        bpy.context.scene.frame_set(3)
        result["invoke_pc2"] = list(bpy.ops.object.sweep_deform_bake(
            'INVOKE_DEFAULT', target='PC2', filepath=os.path.join(OUT, "gui.pc2"), frame_start=70, frame_end=75))
    bpy.app.timers.register(wait_pc2, first_interval=0.5)


@guarded
def wait_pc2():
    if not os.path.exists(os.path.join(OUT, "gui.pc2")):
        return 0.2
    result["pc2_samples"] = helpers.sub("core.cache_files").read_pc2(os.path.join(OUT, "gui.pc2"))[2].shape[0]
    result["frame_after"] = bpy.context.scene.frame_current
    with bpy.context.temp_override(window=window()):
        result["invoke_long"] = list(bpy.ops.object.sweep_deform_bake(
            'INVOKE_DEFAULT', target='MDD', filepath=os.path.join(OUT, "gui_cancel.mdd"), frame_start=1,
            frame_end=240))
    bpy.app.timers.register(esc_during_mdd, first_interval=0.3)


@guarded
def esc_during_mdd():
    partial = os.path.join(OUT, "gui_cancel.mdd.partial")
    vertices = len(bpy.data.objects["Body"].data.vertices)
    if not os.path.exists(partial) or os.path.getsize(partial) < 8 + 4 * 240 + 3 * 12 * vertices:
        return 0.05
    result["partial_seen"] = True
    press_esc()
    bpy.app.timers.register(after_mdd_cancel, first_interval=0.5)


@guarded
def after_mdd_cancel():
    result["mdd_left"] = sorted(f for f in os.listdir(OUT) if f.startswith("gui_cancel"))
    result["frame_after_cancel"] = bpy.context.scene.frame_current
    with bpy.context.temp_override(window=window()):
        result["keys_modal"] = list(bpy.ops.object.sweep_deform_bake(
            'EXEC_DEFAULT', target='SHAPE_KEYS', frame_start=1, frame_end=240, run_modal=True))
    bpy.app.timers.register(esc_during_keys, first_interval=0.3)


@guarded
def esc_during_keys():
    baked = bpy.data.objects.get("Body_baked")
    if baked is None or baked.data.shape_keys is None or len(baked.data.shape_keys.key_blocks) < 4:
        return 0.05
    press_esc()
    bpy.app.timers.register(after_keys_cancel, first_interval=0.5)


@guarded
def after_keys_cancel():
    result["objects"] = sorted(bpy.data.objects.keys())
    result["meshes"] = sorted(bpy.data.meshes.keys())
    result["stack"] = [(m.type, m.show_viewport) for m in bpy.data.objects["Body"].modifiers]
    result["frame_at_end"] = bpy.context.scene.frame_current
    finish()


bpy.app.timers.register(start, first_interval=0.2)
