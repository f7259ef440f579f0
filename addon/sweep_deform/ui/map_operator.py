# SPDX-License-Identifier: GPL-3.0-or-later
"""The "Bind Selected Through Map" operator (blender/bind_through_map.py): select the meshes or point
clouds to bind, then the bound character last (active), as for Blender's "Copy to Selected"
operators. Undoable; in the Object › Sweep Deform menu (and so in F3 search)."""

import bpy
from bpy.props import FloatProperty

from ..blender import bind_through_map, binding
from ..core import native, native_dmap


class OBJECT_OT_sweep_deform_bind_through_map(bpy.types.Operator):
    """Bind the selected meshes or point clouds through the active bound character's
    displacement map: same sweeps and edits, no fitting (another resolution of the same body,
    or a scan)"""
    bl_idname = "object.sweep_deform_bind_through_map"
    bl_label = "Bind Selected Through Map"
    bl_options = {'REGISTER', 'UNDO'}

    snap: FloatProperty(
        name="Snap", default=native_dmap.SNAP_DEFAULT, min=0.0, soft_max=1.0,
        description="Points within this fraction of the local ellipse half-axis of the map's smooth "
                    "surface take the surface's point; others keep their own offsets (0: all keep theirs)")

    @classmethod
    def poll(cls, context):
        source = context.active_object
        if source is None or source.type != 'MESH' or source.sweep_deform.state != 'BOUND':
            cls.poll_message_set("Make a bound Sweep Deform character the active object")
            return False
        if not any(o != source and o.type == 'MESH' for o in context.selected_objects):
            cls.poll_message_set("Also select the meshes or point clouds to bind")
            return False
        return True

    def execute(self, context):
        source = context.active_object
        targets = [o for o in context.selected_objects if o != source and o.type == 'MESH']
        try:
            snapped = bind_through_map.bind_through_map(targets, source, self.snap)
        except (binding.BindError, native.NativeError, native.NativeLibraryError, ValueError) as e:
            self.report({'ERROR'}, f"Sweep Deform: {e}")
            return {'CANCELLED'}
        for t, n in zip(targets, snapped):
            self.report({'INFO'}, f"Sweep Deform: '{t.name}' bound through the map of '{source.name}' "
                                  f"({len(t.data.vertices)} points, {n} influences on the map's surface)")
        return {'FINISHED'}


register, unregister = bpy.utils.register_classes_factory((OBJECT_OT_sweep_deform_bind_through_map,))
