# SPDX-License-Identifier: GPL-3.0-or-later
"""What the .blend keeps: save, reload, deform exactly as before; damaged or outdated data
shows "re-bind needed" instead of a wrong deformation; undo after bind."""

import os

import bpy
import numpy as np
import pytest

import helpers
from test_deform import check_equals_core


@pytest.mark.parametrize("key", ["fixture", "makehuman", "cesium"])
def test_save_reload_exact(key):
    char = helpers.load(key)
    helpers.use_test_rig([char])
    obj = helpers.bind(char)
    obj.sweep_deform.volume_strength = 0.75
    helpers.pose_limbs(char, elbow=1.3, knee=0.9)
    bpy.context.view_layer.update()
    first = check_equals_core(obj)
    helpers.pose_limbs(char, elbow=0.6, knee=1.4)
    bpy.context.view_layer.update()
    second = check_equals_core(obj)
    helpers.pose_limbs(char, elbow=1.3, knee=0.9)
    bpy.context.view_layer.update()
    path = os.path.join(helpers.tmp_dir(), f"reload_{key}.blend")
    bpy.ops.wm.save_as_mainfile(filepath=path)

    bpy.ops.wm.read_homefile(use_empty=True)
    bpy.ops.wm.open_mainfile(filepath=path)
    obj = bpy.data.objects[char.mesh_name]
    assert obj.sweep_deform.state == 'BOUND'
    assert obj.sweep_deform.volume_strength == 0.75
    assert helpers.sub("blender.deformer_cache").peek(obj) is None  # nothing native survives a load
    bpy.context.view_layer.update()
    np.testing.assert_array_equal(helpers.evaluated_positions(obj)[0], first)
    helpers.pose_limbs(char, elbow=0.6, knee=1.4)
    bpy.context.view_layer.update()
    assert helpers.sub("blender.deformer_cache").peek(obj).frames >= 1  # re-created from the blobs, evaluated
    np.testing.assert_array_equal(check_equals_core(obj), second)


def _bound_and_bent_counting_measurements(monkeypatch):
    """The fixture bound and bent at elbows, knees and shoulders; every measurement of the
    joints' volume (by the add-on or by the tests' own core deformer) appends to the list
    returned. Returns (character, mesh object, that list)."""
    native = helpers.sub("core.native")
    measured = []
    measure = native.Deformer.hold_joint_volumes
    monkeypatch.setattr(native.Deformer, "hold_joint_volumes", lambda d, t: measured.append(1) or measure(d, t))
    char = helpers.load("fixture")
    obj = helpers.bind(char)
    helpers.pose_limbs(char, elbow=1.3, knee=0.9, shoulder=0.5)
    bpy.context.view_layer.update()
    return char, obj, measured


def test_an_undo_step_keeps_the_joints_volume_tables(monkeypatch):
    """Undo, redo and load drop every native object, and measuring each limb joint's volume
    again (every joint bent through 24 swings) cost 0.28 s per 53.5K character at every undo
    step. A new entry for the same binding and mesh takes the tables from the deformer it
    replaces: no joint is bent again and the frame is the same to the bit. A new binding
    measures afresh."""
    cache = helpers.sub("blender.deformer_cache")
    char, obj, measured = _bound_and_bent_counting_measurements(monkeypatch)
    before = check_equals_core(obj)  # (which measures the core's own deformer's tables too)
    held = cache.peek(obj).joints_held
    assert held > 0
    n = len(measured)
    helpers.sub("blender.handlers").on_undo_redo_post()  # what an undo step does to the cache
    assert cache.peek(obj) is None
    assert cache.entry(obj).joints_held == held and len(measured) == n  # taken, not measured
    helpers.pose_limbs(char, elbow=0.6, knee=1.4)
    bpy.context.view_layer.update()
    helpers.pose_limbs(char, elbow=1.3, knee=0.9, shoulder=0.5)
    bpy.context.view_layer.update()
    np.testing.assert_array_equal(check_equals_core(obj), before)
    n = len(measured)
    helpers.bind(char)  # another binding: its own measurement
    assert cache.entry(obj).joints_held == held and len(measured) == n + 1


def test_a_file_opened_again_takes_the_joints_volume_tables_it_kept(monkeypatch):
    """A save keeps the joints' volume tables with the binding (the core's blob, and the bind id
    and triangles they were measured on), so the file opened again bends no joint to measure
    them (0.3 s per 53.5K character at every open: a farm's every job) and deforms to the bit
    as before. A damaged blob is measured again and written anew at the next save."""
    cache, persistence = helpers.sub("blender.deformer_cache"), helpers.sub("blender.persistence")
    char, obj, measured = _bound_and_bent_counting_measurements(monkeypatch)
    first, _ = helpers.evaluated_positions(obj)
    held = cache.peek(obj).joints_held
    assert held > 0 and persistence.JOINT_VOLUMES_KEY not in obj  # (kept at save, not before)
    path = os.path.join(helpers.tmp_dir(), "joint_volumes_kept.blend")
    bpy.ops.wm.save_as_mainfile(filepath=path)
    assert persistence.JOINT_VOLUMES_KEY in obj

    bpy.ops.wm.read_homefile(use_empty=True)
    bpy.ops.wm.open_mainfile(filepath=path)
    obj = bpy.data.objects[char.mesh_name]
    n = len(measured)
    helpers.pose_limbs(char, elbow=0.6, knee=1.4)
    bpy.context.view_layer.update()
    helpers.pose_limbs(char, elbow=1.3, knee=0.9, shoulder=0.5)
    bpy.context.view_layer.update()
    assert cache.peek(obj).joints_held == held and len(measured) == n  # read, not measured
    np.testing.assert_array_equal(helpers.evaluated_positions(obj)[0], first)

    kept = bytearray(obj[persistence.JOINT_VOLUMES_KEY])
    kept[-1] ^= 0x20  # its checksum no longer matches
    persistence._put_bytes(obj, persistence.JOINT_VOLUMES_KEY, bytes(kept))
    cache.clear(keep_tables=False)
    assert cache.entry(obj).joints_held == held and len(measured) == n + 1  # measured again
    bpy.ops.wm.save_as_mainfile(filepath=path)
    assert bytes(obj[persistence.JOINT_VOLUMES_KEY]) == cache.peek(obj).deformer.serialize_joint_volumes()


def test_damaged_blob_needs_rebind():
    char = helpers.load("makehuman")
    helpers.use_test_rig([char])
    obj = helpers.bind(char)
    persistence = helpers.sub("blender.persistence")
    blob = bytearray(obj[persistence.BINDING_KEY])
    blob[len(blob) // 2] ^= 0xFF
    persistence._put_bytes(obj, persistence.BINDING_KEY, bytes(blob))
    helpers.sub("blender.deformer_cache").clear()
    helpers.pose_limbs(char, elbow=1.0)
    bpy.context.view_layer.update()
    assert obj.sweep_deform.state == 'REBIND'
    assert "checksum" in obj.sweep_deform.message
    np.testing.assert_array_equal(helpers.evaluated_positions(obj)[0], helpers.base_positions(obj))


def test_changed_armature_rest_pose_needs_rebind():
    char = helpers.load("makehuman")
    helpers.use_test_rig([char])
    obj = helpers.bind(char)
    arm = char.armature
    bpy.context.view_layer.objects.active = arm
    bpy.ops.object.mode_set(mode='EDIT')
    arm.data.edit_bones["lowerarm_l"].tail.z += 0.05
    bpy.ops.object.mode_set(mode='OBJECT')
    helpers.pose_limbs(char, elbow=1.0)
    bpy.context.view_layer.update()
    assert obj.sweep_deform.state == 'REBIND'
    assert "rest pose" in obj.sweep_deform.message


GUI_SCRIPT = r'''
import bpy, json, os, sys
sys.path.insert(0, {here!r})
bpy.ops.preferences.addon_enable(module="bl_ext.user_default.sweep_deform")
import helpers, numpy as np
def step():
    out = {{}}
    try:
        win = bpy.context.window_manager.windows[0]
        with bpy.context.temp_override(window=win):
            char = helpers.Character("makehuman", "Body", "Armature", ["lowerarm_l"], ["calf_l"],
                                     helpers.bone_rig.MAKEHUMAN_CHAINS)
            helpers.use_test_rig([char])
            obj = char.mesh
            bpy.context.view_layer.objects.active = obj
            bpy.ops.ed.undo_push(message="before bind")
            out["add"] = list(bpy.ops.object.sweep_deform_add('EXEC_DEFAULT', True))  # with an undo step, as from the UI
            obj = char.mesh
            out["bound"] = [obj.sweep_deform.state, [(m.name, m.show_viewport) for m in obj.modifiers]]
            out["undo"] = list(bpy.ops.ed.undo())
            obj = char.mesh
            out["undone"] = [obj.sweep_deform.state, [(m.name, m.show_viewport) for m in obj.modifiers],
                             "_sweep_deform_rig" in obj.keys()]
            out["redo"] = list(bpy.ops.ed.redo())
            obj = char.mesh
            out["redone"] = [obj.sweep_deform.state, [(m.name, m.show_viewport) for m in obj.modifiers]]
            helpers.pose_limbs(char, elbow=1.2, knee=0.7)
            bpy.context.view_layer.update()
            co, _ = helpers.evaluated_positions(obj)
            expected, _ = helpers.core_expectation(obj)
            out["deforms_after_redo"] = bool(np.array_equal(co, expected)) and bool(np.abs(co - helpers.base_positions(obj)).max() > 0.05)
            # The interactive path: modal, progress, the native stages in a worker thread.
            helpers.sub("blender.binding").fitter = helpers.sub("blender.binding").fit_native
            out["unbind"] = list(bpy.ops.object.sweep_deform_unbind('EXEC_DEFAULT', True))
            out["invoke"] = list(bpy.ops.object.sweep_deform_bind('INVOKE_DEFAULT'))
    except Exception:
        import traceback
        out["error"] = traceback.format_exc()
        print("RESULT " + json.dumps(out), flush=True)
        os._exit(0)
    bpy.app.timers.register(lambda: finish(out), first_interval=1.0)

def finish(out):
    try:
        win = bpy.context.window_manager.windows[0]
        obj = bpy.data.objects["Body"]
        out["invoked"] = [obj.sweep_deform.state, obj.sweep_deform.sweep_count]
        # Draw the panel (Modifier properties) with live limb volumes.
        for area in win.screen.areas:
            if area.type == 'PROPERTIES':
                area.spaces[0].context = 'MODIFIER'
        helpers.pose_limbs(helpers.Character("makehuman", "Body", "Armature", ["lowerarm_l"], ["calf_l"], []), elbow=1.4, knee=1.2)
        bpy.context.view_layer.update()
        with bpy.context.temp_override(window=win):
            bpy.ops.wm.redraw_timer(type='DRAW_WIN_SWAP', iterations=2)
        out["volumes_drawn"] = helpers.sub("blender.deformer_cache").peek(obj).volumes() is not None
        # Cancel: Esc arrives before the first progress tick; nothing changes.
        with bpy.context.temp_override(window=win):
            bpy.ops.object.sweep_deform_unbind('EXEC_DEFAULT', True)
            out["invoke_again"] = list(bpy.ops.object.sweep_deform_bind('INVOKE_DEFAULT'))
        win.event_simulate(type='ESC', value='PRESS')
        win.event_simulate(type='ESC', value='RELEASE')
    except Exception:
        import traceback
        out["error"] = traceback.format_exc()
        print("RESULT " + json.dumps(out), flush=True)
        os._exit(0)
    bpy.app.timers.register(lambda: after_cancel(out), first_interval=1.0)

def after_cancel(out):
    obj = bpy.data.objects["Body"]
    out["cancelled"] = [obj.sweep_deform.state, [(m.name, m.show_viewport) for m in obj.modifiers]]
    print("RESULT " + json.dumps(out), flush=True)
    os._exit(0)

bpy.app.timers.register(step, first_interval=0.2)
'''


def test_undo_after_bind_in_the_interface():
    """Undo needs a window: a Blender with its interface under Xvfb binds with an undo step,
    undoes (the binding and the modifier go, the Armature modifier deforms again), redoes
    (bound, deforming); then binds as the interface does (modal, with progress) and cancels a
    bind with Esc."""
    helpers.require("makehuman")
    script = os.path.join(helpers.tmp_dir(), "gui_undo.py")
    with open(script, "w") as f:
        f.write(GUI_SCRIPT.format(here=helpers.HERE))
    out, log = helpers.run_gui_blender(os.path.join(helpers.SHARED, "mh_male_game_engine.blend"), script,
                                       timeout=180)
    assert out["add"] == ["FINISHED"]
    assert out["bound"] == ["BOUND", [["Sweep Deform", True], ["Armature", False]]]
    assert out["undone"] == ["UNBOUND", [["Armature", True]], False]
    assert out["redone"] == ["BOUND", [["Sweep Deform", True], ["Armature", False]]]
    assert out["deforms_after_redo"]
    # Invoked from the interface: modal, fitted by the core in a worker thread, then bound.
    assert out["invoke"] == ["RUNNING_MODAL"]
    assert out["invoked"][0] == "BOUND" and out["invoked"][1] >= 5
    # Esc before the job ends: cancelled, the file untouched.
    assert out["invoke_again"] == ["RUNNING_MODAL"]
    assert out["cancelled"] == ["UNBOUND", [["Sweep Deform", True], ["Armature", True]]]
    # The panels drew without a Python error.
    assert out["volumes_drawn"]
    assert "OBJECT_PT_sweep_deform" not in log and "Traceback" not in log, log[-3000:]


WITHOUT_EXTENSION = r'''
import bpy, sys, json, numpy as np
assert not any('sweep_deform' in m for m in sys.modules), 'the extension is loaded'
obj = bpy.data.objects[{mesh!r}]
dg = bpy.context.evaluated_depsgraph_get()
me = obj.evaluated_get(dg).to_mesh()
co = np.empty(len(me.vertices) * 3, np.float32)
me.vertices.foreach_get('co', co)
np.save({dump!r}, co.reshape(-1, 3))
md = obj.modifiers[{arm_md!r}]
sweep = next(m for m in obj.modifiers if m.type == 'NODES')
print("RESULT " + json.dumps(dict(object=md.object.name if md.object else None, viewport=md.show_viewport,
                                  render=md.show_render, sweep=[sweep.show_viewport, sweep.show_render])))
'''


def test_file_saved_bound_deforms_by_armature_modifier_without_extension():
    """Issue 15: a file saved while bound, opened where the extension is missing (a render
    farm node), deforms by its Armature modifier, which still names the armature; the
    extension itself switches that modifier off again after the save and on load."""
    import json
    import subprocess
    char = helpers.load("fixture")
    helpers.use_test_rig([char])
    obj = helpers.bind(char)
    s = obj.sweep_deform
    arm_md = obj.modifiers[s.armature_modifier]
    assert arm_md.object == char.armature and not arm_md.show_viewport and not arm_md.show_render
    helpers.pose_limbs(char, elbow=1.3, knee=0.9)
    bpy.context.view_layer.update()
    sweep = check_equals_core(obj)
    lbs = helpers.armature_modifier_positions(obj)
    assert np.abs(sweep - lbs).max() > 1e-3  # the two deformations differ: the test can tell them apart
    path = os.path.join(helpers.tmp_dir(), "bound_for_farm.blend")
    bpy.ops.wm.save_as_mainfile(filepath=path)
    # After the save, this session goes on with Sweep Deform exactly as before.
    assert not arm_md.show_viewport and not arm_md.show_render and arm_md.object == char.armature
    md_sweep = helpers.sub("blender.modifier").find(obj)
    assert md_sweep.show_viewport and md_sweep.show_render
    bpy.context.view_layer.update()
    np.testing.assert_array_equal(helpers.evaluated_positions(obj)[0], sweep)

    dump = os.path.join(helpers.tmp_dir(), "bound_for_farm.npy")
    if os.path.exists(dump):
        os.remove(dump)
    script = WITHOUT_EXTENSION.format(mesh=obj.name, dump=dump, arm_md=arm_md.name)
    proc = subprocess.run([bpy.app.binary_path, "-b", "--factory-startup", path, "--python-exit-code", "1",
                           "--python-expr", script], capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stdout[-2000:] + proc.stderr[-2000:]
    out = json.loads([x for x in proc.stdout.splitlines() if x.startswith("RESULT ")][-1][len("RESULT "):])
    assert out["object"] == char.armature_name and out["viewport"] and out["render"], out
    assert out["sweep"] == [False, False], out  # never deformed twice
    farm = np.load(dump)
    assert np.abs(farm - lbs).max() <= 1e-5 * helpers.diagonal(lbs), np.abs(farm - lbs).max()

    # With the extension: the same file opens deforming by Sweep Deform, Armature modifier off.
    bpy.ops.wm.open_mainfile(filepath=path)
    obj = bpy.data.objects[char.mesh_name]
    arm_md = obj.modifiers[obj.sweep_deform.armature_modifier]
    assert not arm_md.show_viewport and not arm_md.show_render and arm_md.object == char.armature
    md_sweep = helpers.sub("blender.modifier").find(obj)
    assert md_sweep.show_viewport and md_sweep.show_render
    assert not obj.sweep_deform.saved_for_blender_without_extension
    bpy.context.view_layer.update()
    np.testing.assert_array_equal(helpers.evaluated_positions(obj)[0], sweep)
    helpers.pose_limbs(char, elbow=0.4, knee=1.2)  # and it deforms on
    bpy.context.view_layer.update()
    check_equals_core(obj)


def test_user_toggles_of_the_sweep_modifier_survive_a_save():
    char = helpers.load("fixture")
    helpers.use_test_rig([char])
    obj = helpers.bind(char)
    md_sweep = helpers.sub("blender.modifier").find(obj)
    md_sweep.show_render = False  # the artist's choice
    path = os.path.join(helpers.tmp_dir(), "toggles.blend")
    bpy.ops.wm.save_as_mainfile(filepath=path)
    assert md_sweep.show_viewport and not md_sweep.show_render
    bpy.ops.wm.open_mainfile(filepath=path)
    obj = bpy.data.objects[char.mesh_name]
    md_sweep = helpers.sub("blender.modifier").find(obj)
    assert md_sweep.show_viewport and not md_sweep.show_render
    arm_md = obj.modifiers[obj.sweep_deform.armature_modifier]
    assert not arm_md.show_viewport and not arm_md.show_render
