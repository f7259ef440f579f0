# SPDX-License-Identifier: GPL-3.0-or-later
"""Where the operators appear: the *Object › Sweep Deform* menu (and so F3 search), and
*Add Modifier › Deform › Sweep Deform*."""

import bpy

from . import bind_operators, key_operators, map_operator


class VIEW3D_MT_sweep_deform(bpy.types.Menu):
    bl_label = "Sweep Deform"
    bl_idname = "VIEW3D_MT_sweep_deform"

    def draw(self, context):
        layout = self.layout
        layout.operator(bind_operators.OBJECT_OT_sweep_deform_add.bl_idname, icon='MOD_ARMATURE')
        layout.operator(bind_operators.OBJECT_OT_sweep_deform_bind.bl_idname)
        layout.operator(bind_operators.OBJECT_OT_sweep_deform_unbind.bl_idname)
        layout.separator()
        layout.operator(key_operators.OBJECT_OT_sweep_deform_edit_keys.bl_idname, icon='MESH_CIRCLE')
        layout.separator()
        layout.operator_menu_enum("object.sweep_deform_bake", "target", text="Bake", icon='FILE_CACHE')
        layout.operator(map_operator.OBJECT_OT_sweep_deform_bind_through_map.bl_idname)


def _object_menu(self, context):
    self.layout.separator()
    self.layout.menu(VIEW3D_MT_sweep_deform.bl_idname)


def _modifier_menu(self, context):
    self.layout.operator(bind_operators.OBJECT_OT_sweep_deform_add.bl_idname, text="Sweep Deform",
                         icon='MOD_ARMATURE')


# The Add Modifier menu's Deform column (Blender 4.0+), else nothing there.
_MODIFIER_MENUS = ("OBJECT_MT_modifier_add_deform",)


def register():
    bpy.utils.register_class(VIEW3D_MT_sweep_deform)
    bpy.types.VIEW3D_MT_object.append(_object_menu)
    for name in _MODIFIER_MENUS:
        menu = getattr(bpy.types, name, None)
        if menu is not None:
            menu.append(_modifier_menu)


def unregister():
    for name in _MODIFIER_MENUS:
        menu = getattr(bpy.types, name, None)
        if menu is not None:
            menu.remove(_modifier_menu)
    bpy.types.VIEW3D_MT_object.remove(_object_menu)
    bpy.utils.unregister_class(VIEW3D_MT_sweep_deform)
