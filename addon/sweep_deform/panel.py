# SPDX-License-Identifier: GPL-3.0-or-later
"""The Sweep Deform panel in the Modifier properties (below the stack): armature, bind
state, volume preservation on/off and strength, and the live volume change of each limb."""

import bpy

from . import modifier, native, operators, runtime, rig_io


def _relevant(obj):
    return obj is not None and obj.type == 'MESH' and (
        modifier.find(obj) is not None or obj.sweep_deform.state != 'UNBOUND')


class OBJECT_PT_sweep_deform(bpy.types.Panel):
    bl_label = "Sweep Deform"
    bl_space_type = 'PROPERTIES'
    bl_region_type = 'WINDOW'
    bl_context = "modifier"

    @classmethod
    def poll(cls, context):
        return _relevant(context.object)

    def draw_header(self, context):
        self.layout.label(icon='MOD_ARMATURE')

    def draw(self, context):
        layout = self.layout
        obj = context.object
        s = obj.sweep_deform
        ok, why = native.available()
        if not ok:
            box = layout.box()
            box.alert = True
            box.label(text="Native library unavailable", icon='ERROR')
            for line in _wrap(why):
                box.label(text=line)
            return

        layout.use_property_split = True
        layout.use_property_decorate = False
        col = layout.column()
        col.prop(s, "armature")

        row = layout.row()
        if s.state == 'BOUND':
            row.label(text=f"Bound: {s.sweep_count} sweeps, {s.vertex_count:,} vertices", icon='CHECKMARK')
        elif s.state == 'REBIND':
            box = layout.box()
            box.alert = True
            box.label(text="Re-bind needed", icon='ERROR')
            for line in _wrap(s.message or "The mesh changed after binding"):
                box.label(text=line)
            box.label(text="The mesh is shown undeformed until bound again.")
        else:
            row.label(text="Not bound", icon='UNLINKED')
        if s.state != 'UNBOUND' and s.armature_modifier:
            layout.label(text=f"'{s.armature_modifier}' off while bound", icon='MOD_ARMATURE')
        e = runtime.peek(obj)
        if e is not None and e.error:
            box = layout.box()
            box.alert = True
            for line in _wrap(e.error):
                box.label(text=line)

        row = layout.row(align=True)
        row.operator(operators.OBJECT_OT_sweep_deform_bind.bl_idname,
                     text="Bind" if s.state == 'UNBOUND' else "Bind Again", icon='LINKED')
        if s.state != 'UNBOUND':
            row.operator(operators.OBJECT_OT_sweep_deform_unbind.bl_idname, text="Unbind", icon='UNLINKED')

        if not context.scene.render.use_lock_interface:
            hint = layout.row()
            hint.label(text="Animation renders from the interface: Render > Lock Interface", icon='INFO')

        col = layout.column(heading="Volume")
        col.prop(s, "use_volume_preservation", text="Preserve")
        sub = col.column()
        sub.active = s.use_volume_preservation
        sub.prop(s, "volume_strength")


class OBJECT_PT_sweep_deform_volumes(bpy.types.Panel):
    bl_label = "Limb Volumes"
    bl_space_type = 'PROPERTIES'
    bl_region_type = 'WINDOW'
    bl_context = "modifier"
    bl_parent_id = "OBJECT_PT_sweep_deform"

    @classmethod
    def poll(cls, context):
        obj = context.object
        return _relevant(obj) and obj.sweep_deform.state == 'BOUND'

    def draw(self, context):
        layout = self.layout
        obj = context.object
        e = runtime.peek(obj)
        volumes = e.volumes() if e is not None else None
        if volumes is None:
            layout.label(text="Pose the armature to see the volumes")
            return
        rest, before, after = volumes
        change_before, change_after = rig_io.volume_changes(rest, before, after)
        col = layout.column(align=True)
        head = col.row().split(factor=0.5)
        head.label(text="Limb")
        sub = head.split(factor=0.5)
        sub.label(text="Skinned")
        sub.label(text="Kept")
        for i, label in enumerate(e.labels):
            row = col.row().split(factor=0.5)
            row.label(text=label)
            sub = row.split(factor=0.5)
            sub.label(text=f"{100.0 * change_before[i]:+.1f} %")
            kept = sub.row()
            kept.alert = bool(abs(change_after[i]) > 0.05)
            kept.label(text=f"{100.0 * change_after[i]:+.1f} %")
        layout.label(text="Change from the rest volume, before and after volume control", icon='INFO')


def _wrap(text, width=60):
    words, lines, line = text.split(), [], ""
    for w in words:
        if line and len(line) + 1 + len(w) > width:
            lines.append(line)
            line = w
        else:
            line = f"{line} {w}" if line else w
    if line:
        lines.append(line)
    return lines


classes = (OBJECT_PT_sweep_deform, OBJECT_PT_sweep_deform_volumes)


def register():
    for cls in classes:
        bpy.utils.register_class(cls)


def unregister():
    for cls in reversed(classes):
        bpy.utils.unregister_class(cls)
