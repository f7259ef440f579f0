# SPDX-License-Identifier: GPL-3.0-or-later
"""Operators of key-ellipse editing (Sect. 4.2): Edit Key Ellipses (the overlay, the gizmos and
the tool on or off), delete one correction, clear a key's corrections. The gizmos' own
operators (tweak, select) are in gizmos.py."""

import bpy
from bpy.props import EnumProperty, IntProperty

from ..blender import binding, corrections, key_ellipses, redraw
from . import gizmos
from .bind_operators import active_mesh


def _bound_mesh(context):
    obj = active_mesh(context)
    ok = obj is not None and obj.sweep_deform.state == 'BOUND' and not binding.linked_reason(obj)
    return obj if ok else None


class OBJECT_OT_sweep_deform_edit_keys(bpy.types.Operator):
    """Edit Key Ellipses: draw the sweeps and key ellipses in the viewport, with gizmos on the
    selected key, and make the Edit Key Ellipses tool active (click a key to select it)"""
    bl_idname = "object.sweep_deform_edit_keys"
    bl_label = "Edit Key Ellipses"
    bl_options = {'REGISTER', 'UNDO'}

    action: EnumProperty(name="Action", items=[('TOGGLE', "Toggle", ""), ('ENABLE', "Enable", ""),
                                               ('DISABLE', "Disable", "")], default='TOGGLE')

    @classmethod
    def poll(cls, context):
        if _bound_mesh(context) is None:
            cls.poll_message_set("The active object must be a bound Sweep Deform mesh")
            return False
        return True

    def execute(self, context):
        obj = _bound_mesh(context)
        s = obj.sweep_deform
        enable = {'TOGGLE': not s.edit_keys, 'ENABLE': True, 'DISABLE': False}[self.action]
        s.edit_keys = enable
        if enable and (s.active_sweep < 0 or s.active_key < 0):
            s.active_sweep, s.active_key = key_ellipses.first_joint_key(obj)
        if obj.mode == 'OBJECT':
            try:
                gizmos.activate_tool(context, enable)
            except (RuntimeError, TypeError) as e:  # no 3D viewport (scripts, background)
                print(f"Sweep Deform: tool not switched: {e}")
        redraw.redraw_views()
        return {'FINISHED'}


class OBJECT_OT_sweep_deform_correction_remove(bpy.types.Operator):
    """Delete a key-ellipse correction (its keyframes go with it)"""
    bl_idname = "object.sweep_deform_correction_remove"
    bl_label = "Delete Correction"
    bl_options = {'REGISTER', 'UNDO'}

    index: IntProperty(name="Index", default=-1, min=-1, description="-1: the active correction")

    @classmethod
    def poll(cls, context):
        obj = _bound_mesh(context)
        return obj is not None and len(obj.sweep_deform.corrections) > 0

    def execute(self, context):
        obj = _bound_mesh(context)
        s = obj.sweep_deform
        index = s.active_correction if self.index < 0 else self.index
        if not 0 <= index < len(s.corrections):
            self.report({'ERROR'}, f"Sweep Deform: no correction {index}")
            return {'CANCELLED'}
        corrections.remove_correction(obj, index)
        return {'FINISHED'}


class OBJECT_OT_sweep_deform_key_clear(bpy.types.Operator):
    """Delete every correction of the selected key ellipse"""
    bl_idname = "object.sweep_deform_key_clear"
    bl_label = "Clear Key Corrections"
    bl_options = {'REGISTER', 'UNDO'}

    @classmethod
    def poll(cls, context):
        obj = _bound_mesh(context)
        return obj is not None and obj.sweep_deform.active_key >= 0

    def execute(self, context):
        obj = _bound_mesh(context)
        s = obj.sweep_deform
        for i in reversed(range(len(s.corrections))):
            c = s.corrections[i]
            if c.sweep == s.active_sweep and c.key == s.active_key:
                corrections.remove_correction(obj, i)
        return {'FINISHED'}


classes = (OBJECT_OT_sweep_deform_edit_keys, OBJECT_OT_sweep_deform_correction_remove,
           OBJECT_OT_sweep_deform_key_clear)
register, unregister = bpy.utils.register_classes_factory(classes)
