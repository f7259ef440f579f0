# SPDX-License-Identifier: GPL-3.0-or-later
"""Editing key ellipses in the viewport: the gizmos on the selected key, the operators they
run, the click that selects a key, and the "Edit Key Ellipses" tool.

Every gizmo runs :class:`OBJECT_OT_sweep_deform_key_tweak` (``target_set_operator``), a
modal operator with ``REGISTER``/``UNDO``: the drag updates the correction properties live
(the handlers deform the mesh on every change), and releasing the mouse makes one undo
step; Esc or right click restores the key. Run from a script with ``EXEC_DEFAULT`` the
same operator applies a given amount through the same edit, which is what the tests use:
blender/key_ellipses.py's ``Edit`` (which correction an edit changes, from what values),
through ``apply_edit``.

The gizmos, on the key as it is shown (its own axes: X major, Y minor, Z normal):

* a white ring to move the center in the view plane, an arrow to move it along the normal;
* a blue dial to turn it about its normal; red and green dials to tilt it about its major
  and minor axes;
* a red box on the rim at +a and a green box at +b to scale each half-axis.
"""

import math

import bpy
import numpy as np
from bpy.props import EnumProperty, FloatVectorProperty, IntProperty
from bpy_extras.view3d_utils import location_3d_to_region_2d, region_2d_to_location_3d
from mathutils import Matrix, Vector

from ..blender import deformer_cache, key_ellipses
from ..core import key_edit
from . import overlay

TOOL_ID = "sweep_deform.edit_key_ellipses"
_MODE_ITEMS = [
    ('MOVE', "Move", "Move the center (in the view plane when dragged; amount: a vector in the armature's space)"),
    ('MOVE_X', "Move Along Major Axis", ""),
    ('MOVE_Y', "Move Along Minor Axis", ""),
    ('MOVE_Z', "Move Along Normal", ""),
    ('ROTATE_X', "Tilt About Major Axis", ""),
    ('ROTATE_Y', "Tilt About Minor Axis", ""),
    ('ROTATE_Z', "Turn About Normal", ""),
    ('SCALE_A', "Scale A", "Multiply the half-axis a"),
    ('SCALE_B', "Scale B", "Multiply the half-axis b"),
]


# ---- the edit, as gizmos and scripts make it -------------------------------------------------


def editable(obj):
    return (obj is not None and obj.type == 'MESH' and obj.sweep_deform.state == 'BOUND'
            and obj.mode == 'OBJECT')


def autokey(context, obj, index):
    """With auto keying on, key the edited correction's values at the current frame."""
    ts = context.scene.tool_settings
    if not ts.use_keyframe_insert_auto:
        return
    item = obj.sweep_deform.corrections[index]
    for prop in ("offset", "rotation", "scale_a", "scale_b"):
        item.keyframe_insert(prop)


# ---- screen geometry ------------------------------------------------------------------------


def _region_point(region, rv3d, world):
    p = location_3d_to_region_2d(region, rv3d, Vector(world))
    return None if p is None else np.array(p, np.float64)


class OBJECT_OT_sweep_deform_key_tweak(bpy.types.Operator):
    """Edit the selected key ellipse: move, turn or scale it (the gizmos run this). The edit
    is stored as a correction at the joint's current angle"""
    bl_idname = "object.sweep_deform_key_tweak"
    bl_label = "Edit Key Ellipse"
    bl_options = {'REGISTER', 'UNDO', 'BLOCKING'}

    mode: EnumProperty(name="Mode", items=_MODE_ITEMS, default='MOVE')
    amount: FloatVectorProperty(
        name="Amount", size=3, default=(0.0, 0.0, 0.0),
        description="MOVE: a vector in the armature's space; MOVE_*: a distance; ROTATE_*: radians "
                    "(first value); SCALE_*: a factor (first value)")
    sweep: IntProperty(name="Sweep", default=-1, min=-1, description="-1: the selected key ellipse")
    key: IntProperty(name="Key", default=-1, min=-1, description="-1: the selected key ellipse")

    @classmethod
    def poll(cls, context):
        obj = context.object
        if not editable(obj):
            cls.poll_message_set("The active object must be a bound Sweep Deform mesh in Object Mode")
            return False
        return True

    def _amount(self):
        if self.mode == 'MOVE':
            return np.array(self.amount, np.float64)
        if self.mode.startswith("SCALE_") and self.amount[0] == 0.0:
            return 1.0
        return float(self.amount[0])

    def execute(self, context):
        obj = context.object
        try:
            key_ellipses.apply_edit(obj, self.mode, self._amount(), self.sweep, self.key)
        except (ValueError, RuntimeError) as e:
            self.report({'ERROR'}, f"Sweep Deform: {e}")
            return {'CANCELLED'}
        autokey(context, obj, obj.sweep_deform.active_correction)
        return {'FINISHED'}

    # -- interactive: the gizmos ----------------------------------------------------------------

    def invoke(self, context, event):
        obj = context.object
        region, rv3d = context.region, context.region_data
        if region is None or rv3d is None or context.area is None or context.area.type != 'VIEW_3D':
            return self.execute(context)
        sweep, key = key_ellipses.selected_key(obj, self.sweep, self.key)
        if sweep < 0 or key < 0:
            self.report({'WARNING'}, "Sweep Deform: select a key ellipse first")
            return {'CANCELLED'}
        try:
            self._edit = key_ellipses.Edit(obj, sweep, key)
        except (ValueError, RuntimeError) as e:
            self.report({'ERROR'}, f"Sweep Deform: {e}")
            return {'CANCELLED'}
        st = self._edit.state
        m = overlay.world_matrix(obj)
        self._to_world = m
        center_w = m[:3, :3] @ st["shown_center"] + m[:3, 3]
        axes_w = m[:3, :3] @ st["shown_rotation"]
        self._center_w = center_w
        self._center2d = _region_point(region, rv3d, center_w)
        self._mouse0 = np.array((event.mouse_region_x, event.mouse_region_y), np.float64)
        self._region, self._rv3d = region, rv3d
        if self._center2d is None:
            self._edit.cancel()
            return {'CANCELLED'}
        mode = self.mode
        self._tip2d = None
        if mode in ("MOVE_X", "MOVE_Y", "MOVE_Z"):
            axis = axes_w[:, "XYZ".index(mode[-1])]
            self._length = max(float(st["shown_half_axes"].max()), 1e-3)
            self._tip2d = _region_point(region, rv3d, center_w + axis * self._length)
        elif mode in ("SCALE_A", "SCALE_B"):
            i = 0 if mode == "SCALE_A" else 1
            self._tip2d = _region_point(region, rv3d, center_w + axes_w[:, i] * st["shown_half_axes"][i])
        elif mode.startswith("ROTATE_"):
            axis = axes_w[:, "XYZ".index(mode[-1])]
            view_dir = np.array(rv3d.view_rotation @ Vector((0.0, 0.0, -1.0)), np.float64)
            self._facing = -1.0 if float(axis @ view_dir) > 0.0 else 1.0
        context.window_manager.modal_handler_add(self)
        context.workspace.status_text_set("Sweep Deform: drag to edit the key ellipse · Esc/right click cancels")
        return {'RUNNING_MODAL'}

    def _drag(self, context, event):
        mouse = np.array((event.mouse_region_x, event.mouse_region_y), np.float64)
        mode = self.mode
        if mode == "MOVE":
            a = region_2d_to_location_3d(self._region, self._rv3d, Vector(self._mouse0), Vector(self._center_w))
            b = region_2d_to_location_3d(self._region, self._rv3d, Vector(mouse), Vector(self._center_w))
            world = np.array(b - a, np.float64)
            amount = np.linalg.solve(self._to_world[:3, :3], world)  # into the armature's space
            self.amount = amount
        elif mode in ("MOVE_X", "MOVE_Y", "MOVE_Z"):
            # The tip is `length` armature units along the axis: the drag comes out in those units.
            amount = 0.0 if self._tip2d is None else key_edit.axis_drag(self._mouse0, mouse, self._center2d,
                                                                        self._tip2d, self._length)
            self.amount = (amount, 0.0, 0.0)
        elif mode.startswith("ROTATE_"):
            amount = key_edit.dial_drag(self._center2d, self._mouse0, mouse, self._facing)
            if event.ctrl:
                amount = math.radians(5.0) * round(math.degrees(amount) / 5.0)
            self.amount = (amount, 0.0, 0.0)
        else:
            amount = 1.0 if self._tip2d is None else key_edit.scale_drag(self._mouse0, mouse, self._center2d,
                                                                         self._tip2d)
            self.amount = (amount, 0.0, 0.0)
        if event.shift and mode != "MOVE":  # precision
            a0 = 1.0 if mode.startswith("SCALE_") else 0.0
            self.amount = (a0 + 0.1 * (self.amount[0] - a0), 0.0, 0.0)
        self._edit.set(mode, self._amount())

    def modal(self, context, event):
        if event.type in {'MOUSEMOVE', 'INBETWEEN_MOUSEMOVE'}:
            self._drag(context, event)
            return {'RUNNING_MODAL'}
        if event.type in {'LEFTMOUSE', 'RET', 'NUMPAD_ENTER'} and event.value in {'RELEASE', 'PRESS'}:
            if event.type == 'LEFTMOUSE' and event.value == 'PRESS':
                return {'RUNNING_MODAL'}
            context.workspace.status_text_set(None)
            autokey(context, self._edit.obj, self._edit.index)
            return {'FINISHED'}
        if event.type in {'ESC', 'RIGHTMOUSE'} and event.value == 'PRESS':
            self._edit.cancel()
            context.workspace.status_text_set(None)
            return {'CANCELLED'}
        return {'RUNNING_MODAL'}


class OBJECT_OT_sweep_deform_select_key(bpy.types.Operator):
    """Select the key ellipse under the mouse (the nearest drawn ellipse)"""
    bl_idname = "object.sweep_deform_select_key"
    bl_label = "Select Key Ellipse"
    bl_options = {'REGISTER', 'UNDO'}

    sweep: IntProperty(name="Sweep", default=-1, min=-1)
    key: IntProperty(name="Key", default=-1, min=-1)
    radius: IntProperty(name="Radius", default=30, min=1, description="Pixels from an ellipse that still pick it")

    @classmethod
    def poll(cls, context):
        return editable(context.object)

    def execute(self, context):
        obj = context.object
        s = obj.sweep_deform
        if self.sweep >= s.sweep_count or (self.sweep >= 0 and self.key < 0):
            self.report({'ERROR'}, "Sweep Deform: no such key ellipse")
            return {'CANCELLED'}
        if self.sweep >= 0:
            e = deformer_cache.entry(obj)
            if e.rig is None or self.key >= e.rig.key_count(self.sweep):
                self.report({'ERROR'}, "Sweep Deform: no such key ellipse")
                return {'CANCELLED'}
        if not s.edit_keys:
            s.edit_keys = True
        s.active_sweep, s.active_key = self.sweep, self.key
        return {'FINISHED'}

    def invoke(self, context, event):
        obj = context.object
        region, rv3d = context.region, context.region_data
        if region is None or rv3d is None:
            return self.execute(context)
        mouse = (event.mouse_region_x, event.mouse_region_y)
        candidates = []
        for o in overlay.edited_objects(context) or [obj]:
            for s, k, pts in overlay.key_loops(o):
                candidates.append((o, s, k, pts))
        persp = np.array(rv3d.perspective_matrix, np.float64)
        loops = [key_edit.project(pts, persp, region.width, region.height) for _, _, _, pts in candidates]
        best, _ = key_edit.nearest_loop(mouse, loops, self.radius)
        if best is None:
            self.sweep, self.key = -1, -1
            return self.execute(context)
        o, self.sweep, self.key, _ = candidates[best]
        if o != obj:
            context.view_layer.objects.active = o
        return self.execute(context)


# ---- the gizmo group ------------------------------------------------------------------------


def _basis(center, x, y, z):
    m = Matrix.Identity(4)
    for r in range(3):
        m[r][0], m[r][1], m[r][2], m[r][3] = x[r], y[r], z[r], center[r]
    return m


class VIEW3D_GGT_sweep_deform_key(bpy.types.GizmoGroup):
    bl_idname = "VIEW3D_GGT_sweep_deform_key"
    bl_label = "Sweep Deform Key Ellipse"
    bl_space_type = 'VIEW_3D'
    bl_region_type = 'WINDOW'
    bl_options = {'3D', 'PERSISTENT', 'SHOW_MODAL_ALL'}

    @classmethod
    def poll(cls, context):
        obj = context.object
        if not editable(obj):
            return False
        s = obj.sweep_deform
        return s.edit_keys and s.active_sweep >= 0 and s.active_key >= 0

    def _new(self, kind, mode, color, **options):
        gz = self.gizmos.new(kind)
        props = gz.target_set_operator(OBJECT_OT_sweep_deform_key_tweak.bl_idname)
        props.mode = mode
        gz.color = color
        gz.alpha = 0.7
        gz.color_highlight = tuple(min(1.0, c + 0.3) for c in color)
        gz.alpha_highlight = 1.0
        for name, value in options.items():
            setattr(gz, name, value)
        return gz

    def setup(self, context):
        red, green, blue, white = (0.9, 0.2, 0.3), (0.4, 0.8, 0.1), (0.2, 0.5, 1.0), (0.9, 0.9, 0.9)
        self.move = self._new("GIZMO_GT_move_3d", 'MOVE', white, draw_style='RING_2D', scale_basis=0.18,
                              line_width=2.0)
        self.move.draw_options = {'ALIGN_VIEW', 'FILL_SELECT'}
        self.normal = self._new("GIZMO_GT_arrow_3d", 'MOVE_Z', blue, line_width=2.0, scale_basis=0.9)
        self.turn = self._new("GIZMO_GT_dial_3d", 'ROTATE_Z', blue, line_width=3.0, scale_basis=0.9)
        self.tilt_x = self._new("GIZMO_GT_dial_3d", 'ROTATE_X', red, line_width=3.0, scale_basis=0.9)
        self.tilt_y = self._new("GIZMO_GT_dial_3d", 'ROTATE_Y', green, line_width=3.0, scale_basis=0.9)
        for dial in (self.turn, self.tilt_x, self.tilt_y):
            dial.draw_options = {'CLIP'}
        self.scale_a = self._new("GIZMO_GT_arrow_3d", 'SCALE_A', red, draw_style='BOX', line_width=2.0,
                                 scale_basis=0.6)
        self.scale_b = self._new("GIZMO_GT_arrow_3d", 'SCALE_B', green, draw_style='BOX', line_width=2.0,
                                 scale_basis=0.6)
        self.refresh(context)

    def refresh(self, context):
        obj = context.object
        s = obj.sweep_deform
        data = key_ellipses.overlay_data(obj)
        if not data or s.active_sweep >= len(data) or s.active_key >= len(data[s.active_sweep]["centers"]):
            for gz in self.gizmos:
                gz.hide = True
            return
        sw = data[s.active_sweep]
        k = s.active_key
        m = overlay.world_matrix(obj)
        c = m[:3, :3] @ sw["centers"][k] + m[:3, 3]
        R = m[:3, :3] @ sw["rotations"][k]
        x, y, z = (R[:, i] / (np.linalg.norm(R[:, i]) or 1.0) for i in range(3))
        a, b = (float(v) * float(np.linalg.norm(m[:3, 0])) for v in sw["half_axes"][k])
        for gz in self.gizmos:
            gz.hide = False
        self.move.matrix_basis = _basis(c, x, y, z)
        self.normal.matrix_basis = _basis(c, x, y, z)
        self.turn.matrix_basis = _basis(c, x, y, z)
        self.tilt_x.matrix_basis = _basis(c, y, z, x)
        self.tilt_y.matrix_basis = _basis(c, z, x, y)
        self.scale_a.matrix_basis = _basis(c + a * x, y, z, x)
        self.scale_b.matrix_basis = _basis(c + b * y, z, x, y)

    def draw_prepare(self, context):
        self.refresh(context)


# ---- the tool ---------------------------------------------------------------------------------


class VIEW3D_TL_sweep_deform_edit_keys(bpy.types.WorkSpaceTool):
    bl_space_type = 'VIEW_3D'
    bl_context_mode = 'OBJECT'
    bl_idname = TOOL_ID
    bl_label = "Edit Key Ellipses"
    bl_description = ("Sweep Deform: click a key ellipse to select it, then move, turn or scale it with its "
                      "gizmos; the edit is kept for the joint's current angle")
    bl_icon = "ops.gpencil.primitive_circle"
    bl_widget = None
    bl_keymap = (
        (OBJECT_OT_sweep_deform_select_key.bl_idname, {"type": 'LEFTMOUSE', "value": 'CLICK'}, None),
    )

    def draw_settings(context, layout, tool):
        obj = context.object
        if obj is None or obj.type != 'MESH' or obj.sweep_deform.state != 'BOUND':
            layout.label(text="Select a bound Sweep Deform mesh")
            return
        s = obj.sweep_deform
        layout.prop(s, "edit_keys", text="Overlay")
        layout.prop(s, "show_sweeps")
        layout.prop(s, "active_sweep")
        layout.prop(s, "active_key")


def activate_tool(context, enable):
    """Makes the Edit Key Ellipses tool active (or the default select tool again) in every
    3D viewport of the window."""
    screen = getattr(context, "screen", None)
    if screen is None:
        return
    for area in screen.areas:
        if area.type != 'VIEW_3D':
            continue
        region = next((r for r in area.regions if r.type == 'WINDOW'), None)
        with context.temp_override(area=area, region=region):
            current = context.workspace.tools.from_space_view3d_mode(context.mode, create=False)
            if enable:
                bpy.ops.wm.tool_set_by_id(name=TOOL_ID)
            elif current is not None and current.idname == TOOL_ID:
                bpy.ops.wm.tool_set_by_id(name="builtin.select_box")


classes = (OBJECT_OT_sweep_deform_key_tweak, OBJECT_OT_sweep_deform_select_key, VIEW3D_GGT_sweep_deform_key)


def register():
    for cls in classes:
        bpy.utils.register_class(cls)
    try:
        bpy.utils.register_tool(VIEW3D_TL_sweep_deform_edit_keys, after={"builtin.scale_cage"}, separator=True,
                                group=False)
    except (ValueError, RuntimeError) as e:  # e.g. a toolbar layout without that anchor
        print(f"Sweep Deform: the Edit Key Ellipses tool was not added: {e}")


def unregister():
    try:
        bpy.utils.unregister_tool(VIEW3D_TL_sweep_deform_edit_keys)
    except (ValueError, RuntimeError, KeyError):
        pass
    for cls in reversed(classes):
        bpy.utils.unregister_class(cls)
