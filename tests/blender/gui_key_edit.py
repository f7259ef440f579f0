# SPDX-License-Identifier: GPL-3.0-or-later
"""Run by test_key_edit.py in a GUI Blender under Xvfb (undo needs a window; the overlay and
the gizmos need a viewport):

    blender --factory-startup -p 0 0 W H --enable-event-simulate CHARACTER.blend \\
        --python gui_key_edit.py -- OUT_DIR

1. binds the character (core fitting), turns Edit Key Ellipses on (the panel's toggle:
   overlay, tool, gizmos) and selects the left elbow key;
2. at the `rest` marker: draws and grabs the screen (scripts/xgrab.py) → OUT_DIR/edit_rest.png;
3. at the `elbow_bend` marker (150°): edits the key with the gizmos' operator as the
   interface runs it (one undo step each), grabs → OUT_DIR/edit_elbow.png;
4. undo: the deformation is exactly the one before the edits; redo: exactly the edited one;
5. prints ``RESULT {json}``: the measurements, and for each screenshot the window-space pixels
   where the key ellipses project (the test looks for the overlay's colour there).
"""

import os
import subprocess
import sys
import traceback

import bpy

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
REPO = os.path.dirname(os.path.dirname(HERE))
OUT = sys.argv[sys.argv.index("--") + 1] if "--" in sys.argv else "/tmp"

bpy.ops.preferences.addon_enable(module="bl_ext.user_default.sweep_deform")

import numpy as np  # noqa: E402

import helpers  # noqa: E402
from gui_support import finish, guarded, result as out  # noqa: E402


def window_and_view():
    win = bpy.context.window_manager.windows[0]
    area = max((a for a in win.screen.areas if a.type == 'VIEW_3D'), key=lambda a: a.width * a.height)
    region = next(r for r in area.regions if r.type == 'WINDOW')
    return win, area, region


def elbow_key(obj):
    """(sweep, key) of the left elbow's joint key."""
    e = helpers.sub("blender.deformer_cache").entry(obj)
    names = e.bone_names
    for s in range(e.rig.sweep_count):
        keys = e.rig.keys(s)
        for k in range(len(keys["bones"])):
            if keys["joint_parents"][k] >= 0 and names[keys["bones"][k]] == "forearm.L":
                return s, k
    raise RuntimeError("no elbow key")


def positions(obj):
    bpy.context.view_layer.update()
    return helpers.evaluated_positions(obj)[0]


def frame(name):
    scene = bpy.context.scene
    scene.frame_set({m.name: m.frame for m in scene.timeline_markers}[name])


def projected_keys(obj, region, rv3d):
    """Window pixels (x, y from the bottom-left) of points on every drawn key ellipse."""
    from bpy_extras.view3d_utils import location_3d_to_region_2d
    from mathutils import Vector
    overlay = helpers.sub("ui.overlay")
    # Regions drawn over the viewport (sidebar, toolbar, headers) hide what is under them.
    area = next(a for a in bpy.context.window_manager.windows[0].screen.areas
                if any(r.as_pointer() == region.as_pointer() for r in a.regions))
    covers = [(r.x - 4, r.y - 4, r.x + r.width + 4, r.y + r.height + 4) for r in area.regions
              if r.type != 'WINDOW' and r.width > 1 and r.height > 1]
    pts = []
    for _, _, loop in overlay.key_loops(obj):
        for p in loop[::4]:
            q = location_3d_to_region_2d(region, rv3d, Vector(p))
            if q is None or not (4 <= q.x < region.width - 4 and 4 <= q.y < region.height - 4):
                continue
            x, y = region.x + q.x, region.y + q.y
            if any(x0 <= x <= x1 and y0 <= y <= y1 for x0, y0, x1, y1 in covers):
                continue
            pts.append([x, y])
    return pts


def grab(name, obj):
    win, area, region = window_and_view()
    with bpy.context.temp_override(window=win, area=area, region=region):
        bpy.ops.wm.redraw_timer(type='DRAW_WIN_SWAP', iterations=2)
    path = os.path.join(OUT, name)
    proc = subprocess.run(["python3", os.path.join(REPO, "scripts", "xgrab.py"), path], capture_output=True, text=True)
    out.setdefault("grabs", {})[name] = dict(
        path=path, ok=proc.returncode == 0 and os.path.isfile(path), log=proc.stdout + proc.stderr,
        window=[win.width, win.height], points=projected_keys(obj, region, area.spaces[0].region_3d))


@guarded
def step1():
    win, area, region = window_and_view()
    obj = bpy.data.objects["Body"]
    with bpy.context.temp_override(window=win, area=area, region=region):
        bpy.context.view_layer.objects.active = obj
        obj.select_set(True)
        out["bind"] = list(bpy.ops.object.sweep_deform_add('EXEC_DEFAULT', True))
        out["edit_keys"] = list(bpy.ops.object.sweep_deform_edit_keys('EXEC_DEFAULT', True, action='ENABLE'))
        tool = bpy.context.workspace.tools.from_space_view3d_mode('OBJECT', create=False)
        out["tool"] = tool.idname if tool else None
        sweep, key = elbow_key(obj)
        out["select"] = list(bpy.ops.object.sweep_deform_select_key('EXEC_DEFAULT', True, sweep=sweep, key=key))
    # A view of the upper body from the front and the character's left, the modifier panel open.
    space = area.spaces[0]
    rv3d = space.region_3d
    from mathutils import Euler, Vector
    rv3d.view_perspective = 'PERSP'
    rv3d.view_rotation = Euler((1.35, 0.0, 0.45)).to_quaternion()
    rv3d.view_location = Vector((0.25, -0.05, 1.18))
    rv3d.view_distance = 1.55
    space.overlay.show_floor = True
    frame("rest")
    out["rest_positions_equal_mesh"] = bool(np.array_equal(positions(obj), helpers.base_positions(obj)))
    bpy.app.timers.register(step2, first_interval=1.0)


@guarded
def step2():
    obj = bpy.data.objects["Body"]
    s = obj.sweep_deform
    win, _, _ = window_and_view()
    for a in win.screen.areas:  # the modifier tab (offered once the editor has seen the mesh active)
        if a.type == 'PROPERTIES':
            try:
                a.spaces[0].context = 'MODIFIER'
            except TypeError:
                pass
    out["gizmos_poll"] = bool(helpers.sub("ui.gizmos").VIEW3D_GGT_sweep_deform_key.poll(bpy.context)) \
        if bpy.context.object else None
    grab("edit_rest.png", obj)
    frame("elbow_bend")
    win, area, region = window_and_view()
    before = positions(obj)
    with bpy.context.temp_override(window=win, area=area, region=region):
        bpy.ops.ed.undo_push(message="before the key edits")
        # The gizmos' operator as the interface runs it (each makes an undo step).
        for mode, amount in (('SCALE_A', 1.35), ('ROTATE_X', 0.25), ('MOVE_Y', 0.015)):
            out.setdefault("tweaks", []).append(
                list(bpy.ops.object.sweep_deform_key_tweak('EXEC_DEFAULT', True, mode=mode, amount=(amount, 0, 0))))
    after = positions(obj)
    c = s.corrections[0]
    out["correction"] = [len(s.corrections), c.sweep, c.key, c.angle, list(c.offset), list(c.rotation), c.scale_a,
                         c.scale_b]
    out["edit_moved"] = float(np.linalg.norm(after - before, axis=1).max())
    with bpy.context.temp_override(window=win, area=area, region=region):
        for _ in range(3):
            bpy.ops.ed.undo()
    obj = bpy.data.objects["Body"]
    undone = positions(obj)
    out["undone"] = [len(obj.sweep_deform.corrections), bool(np.array_equal(undone, before)),
                     float(np.abs(undone - before).max())]
    with bpy.context.temp_override(window=win, area=area, region=region):
        for _ in range(3):
            bpy.ops.ed.redo()
    obj = bpy.data.objects["Body"]
    redone = positions(obj)
    out["redone"] = [len(obj.sweep_deform.corrections), bool(np.array_equal(redone, after)),
                     float(np.abs(redone - after).max())]
    bpy.app.timers.register(step3, first_interval=1.0)


@guarded
def step3():
    obj = bpy.data.objects["Body"]
    # The viewport's sidebar, Sweep Deform tab: the Key Ellipses panel with the corrections.
    win, area, region = window_and_view()
    area.spaces[0].show_region_ui = True
    bpy.app.timers.register(step3a, first_interval=1.0)


@guarded
def step3a():
    win, area, region = window_and_view()
    for r in area.regions:  # the tab exists once the sidebar has been drawn
        if r.type == 'UI' and hasattr(r, "active_panel_category"):
            try:
                r.active_panel_category = "Sweep Deform"
            except (TypeError, AttributeError) as e:
                out["sidebar_tab"] = str(e)
    bpy.app.timers.register(step3b, first_interval=1.0)


@guarded
def step3b():
    obj = bpy.data.objects["Body"]
    grab("edit_elbow.png", obj)
    # A real drag of a gizmo, with simulated mouse events: hover the key's center (the move
    # ring), press, drag 40 px to the right, release.
    win, area, region = window_and_view()
    st = helpers.sub("blender.key_ellipses").key_state(obj, obj.sweep_deform.active_sweep, obj.sweep_deform.active_key)
    from bpy_extras.view3d_utils import location_3d_to_region_2d
    from mathutils import Vector
    m = helpers.sub("ui.overlay").world_matrix(obj)
    c = location_3d_to_region_2d(region, area.spaces[0].region_3d, Vector(m[:3, :3] @ st["shown_center"] + m[:3, 3]))
    x, y = int(region.x + c.x), int(region.y + c.y)
    out["drag_from"] = [x, y]
    out["drag_offset_before"] = list(obj.sweep_deform.corrections[0].offset)
    global _before_drag
    _before_drag = positions(obj)
    steps = [("MOUSEMOVE", 'NOTHING', x, y), ("MOUSEMOVE", 'NOTHING', x + 1, y), ("LEFTMOUSE", 'PRESS', x + 1, y)]
    steps += [("MOUSEMOVE", 'NOTHING', x + 1 + dx, y) for dx in (5, 10, 20, 30, 40)]
    steps += [("LEFTMOUSE", 'RELEASE', x + 41, y)]
    _simulate(steps, after_drag)


_before_drag = None


def _simulate(steps, then):
    win = bpy.context.window_manager.windows[0]

    def next_event():
        try:
            if not steps:
                bpy.app.timers.register(guarded(then), first_interval=0.5)
                return None
            kind, value, x, y = steps.pop(0)
            win.event_simulate(type=kind, value=value, x=x, y=y)
            return 0.15
        except Exception:
            out["error"] = traceback.format_exc()
            finish()
    bpy.app.timers.register(next_event, first_interval=0.2)


def after_drag():
    obj = bpy.data.objects["Body"]
    s = obj.sweep_deform
    out["drag_offset_after"] = list(s.corrections[0].offset) if len(s.corrections) else None
    dragged = positions(obj)
    out["drag_moved"] = float(np.linalg.norm(dragged - _before_drag, axis=1).max())
    win, area, region = window_and_view()
    with bpy.context.temp_override(window=win, area=area, region=region):
        bpy.ops.ed.undo()
    obj = bpy.data.objects["Body"]  # undo replaced the data: fetch it again
    s = obj.sweep_deform
    out["drag_undone"] = bool(np.array_equal(positions(obj), _before_drag))
    # A click on another key ellipse selects it (the tool's keymap): the wrist key of the
    # left arm (the last key of the elbow's sweep), at a point of its drawn ellipse.
    sweep = s.active_sweep
    loops = [(k, pts) for sw, k, pts in helpers.sub("ui.overlay").key_loops(obj) if sw == sweep]
    k_last, pts = loops[-1]
    from bpy_extras.view3d_utils import location_3d_to_region_2d
    from mathutils import Vector
    p = location_3d_to_region_2d(region, area.spaces[0].region_3d, Vector(pts[0]))
    x, y = int(region.x + p.x), int(region.y + p.y)
    out["click_target"] = [sweep, k_last]
    _simulate([("MOUSEMOVE", 'NOTHING', x, y), ("LEFTMOUSE", 'PRESS', x, y), ("LEFTMOUSE", 'RELEASE', x, y)],
              after_click)


def after_click():
    s = bpy.data.objects["Body"].sweep_deform
    out["clicked"] = [s.active_sweep, s.active_key]
    finish()


bpy.app.timers.register(step1, first_interval=0.5)
