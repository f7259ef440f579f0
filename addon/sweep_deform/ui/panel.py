# SPDX-License-Identifier: GPL-3.0-or-later
"""The Sweep Deform panel in the Modifier properties (below the stack): armature, bind
state, volume preservation on/off and strength, the live volume change of each limb, and
the key-ellipse editing (Sect. 4.2): the Edit Key Ellipses toggle, the selected key, and the
corrections (a list to select, mute and delete them; the active one's values, which can be
keyframed). The editing part is also in the 3D viewport's sidebar (Sweep Deform tab)."""

import bpy

from ..blender import deformer_cache, key_ellipses, modifier
from ..core import arrays, key_edit, native
from . import bind_operators, key_operators


def _alert_box(layout, text, title=None):
    """A red box with `text` wrapped, under an optional `title` with an error icon."""
    box = layout.box()
    box.alert = True
    if title:
        box.label(text=title, icon='ERROR')
    for line in _wrap(text):
        box.label(text=line)


def _bound(obj):
    return _relevant(obj) and obj.sweep_deform.state == 'BOUND'


def _relevant(obj):
    return obj is not None and obj.type == 'MESH' and (
        modifier.find(obj) is not None or obj.sweep_deform.state != 'UNBOUND')


def vertex_count_problem(context, obj):
    """The panel's message when a modifier before Sweep Deform changes (or may change) the
    vertex count (the modifier then passes the geometry through unchanged), else None."""
    s = obj.sweep_deform
    md = modifier.find(obj)
    if md is None or s.state != 'BOUND':
        return None
    try:
        count = len(obj.evaluated_get(context.view_layer.depsgraph).data.vertices)
    except (AttributeError, RuntimeError, ReferenceError):
        count = None
    return modifier.count_problem(obj, md, s.vertex_count, count)


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
        e = deformer_cache.peek(obj)
        if e is not None and e.error:
            _alert_box(layout, e.error)
        if e is not None and e.warning:
            _alert_box(layout, e.warning, "Extreme pose")
        if e is not None and e.joint_volume_error:
            _alert_box(layout, e.joint_volume_error, "Volume at the joints")
        if e is not None and e.trunk_fill_error:
            _alert_box(layout, e.trunk_fill_error, "Volume of the trunk")
        problem = vertex_count_problem(context, obj)
        if problem:
            _alert_box(layout, problem, "Vertex count changed before Sweep Deform")

        row = layout.row(align=True)
        row.operator(bind_operators.OBJECT_OT_sweep_deform_bind.bl_idname,
                     text="Bind" if s.state == 'UNBOUND' else "Bind Again", icon='LINKED')
        if s.state != 'UNBOUND':
            row.operator(bind_operators.OBJECT_OT_sweep_deform_unbind.bl_idname, text="Unbind", icon='UNLINKED')
        if s.state == 'BOUND':
            layout.operator_menu_enum("object.sweep_deform_bake", "target", text="Bake", icon='FILE_CACHE')

        if not context.scene.render.use_lock_interface:
            hint = layout.row()
            hint.label(text="Animation renders from the interface: Render > Lock Interface", icon='INFO')

        col = layout.column(heading="Volume")
        col.prop(s, "use_volume_preservation", text="Preserve")
        sub = col.column()
        sub.active = s.use_volume_preservation
        sub.prop(s, "volume_strength")


class _BoundSubPanel:
    """A sub-panel of the modifier's panel, shown for a bound mesh."""
    bl_space_type = 'PROPERTIES'
    bl_region_type = 'WINDOW'
    bl_context = "modifier"
    bl_parent_id = "OBJECT_PT_sweep_deform"

    @classmethod
    def poll(cls, context):
        return _bound(context.object)


class OBJECT_PT_sweep_deform_volumes(_BoundSubPanel, bpy.types.Panel):
    bl_label = "Limb Volumes"

    def draw(self, context):
        layout = self.layout
        obj = context.object
        e = deformer_cache.peek(obj)
        volumes = e.volumes() if e is not None else None
        if volumes is None:
            layout.label(text="Pose the armature to see the volumes")
            return
        rest, before, after = volumes
        change_before, change_after = arrays.volume_changes(rest, before, after)
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


class OBJECT_PT_sweep_deform_anatomy(_BoundSubPanel, bpy.types.Panel):
    """Anatomical effects (Sect. 4.3, 4.4): on/off, per joint folding / protrusion / bulge
    and their strengths, and the last frame's figures."""
    bl_label = "Anatomical Effects"
    bl_options = {'DEFAULT_CLOSED'}

    def draw_header(self, context):
        self.layout.prop(context.object.sweep_deform, "use_anatomy", text="")

    def draw(self, context):
        layout = self.layout
        obj = context.object
        s = obj.sweep_deform
        layout.active = s.use_anatomy
        if not s.joints:
            layout.label(text="No elbows or knees known yet" if not s.use_anatomy else
                         "No elbows or knees in the fitting report", icon='INFO')
        for j in s.joints:
            box = layout.box()
            row = box.row(align=True)
            row.label(text=j.name or j.bone, icon='BONE_DATA')
            row.prop(j, "use_folding", toggle=True)
            row.prop(j, "use_protrusion", toggle=True)
            row.prop(j, "use_bulge", toggle=True)
            row = box.row(align=True)
            sub = row.row(align=True)
            sub.active = j.use_protrusion
            sub.prop(j, "protrusion_strength", text="Protrusion")
            sub = row.row(align=True)
            sub.active = j.use_bulge
            sub.prop(j, "bulge_strength", text="Bulge")
        e = deformer_cache.peek(obj)
        if e is None or not s.use_anatomy:
            return
        if e.anatomy_error:
            box = layout.box()
            box.alert = True
            for line in _wrap(e.anatomy_error):
                box.label(text=line)
        st = e.anatomy_stats
        if st is None:
            layout.label(text="Pose the armature to see the figures")
            return
        col = layout.column(align=True)
        col.label(text=f"Intersecting pairs: {int(st['pairs_before'])} before folding, "
                       f"{int(st['pairs_after'])} after")
        col.label(text=f"Last frame: {st['ms_total']:.2f} ms (collision {st['ms_collision']:.2f}, "
                       f"folding {st['ms_folding']:.2f})")
        col.label(text=f"Vertices: {int(st['folded_vertices'])} folded, {int(st['protrusion_vertices'])} "
                       f"protruded, {int(st['bulge_vertices'])} bulged")


# ---- key-ellipse editing (Sect. 4.2) ---------------------------------------------------------


def key_label(obj, sweep, key):
    """A readable name of a key ellipse: limb, index, role and joint bone."""
    e = deformer_cache.peek(obj)
    if e is None or e.rig is None or not 0 <= sweep < e.rig.sweep_count:
        return f"sweep {sweep} · key {key}"
    K = e.rig.key_count(sweep)
    if not 0 <= key < K:
        return f"sweep {sweep} · key {key}"
    label = e.labels[sweep] if sweep < len(e.labels) else f"sweep {sweep}"
    joint_key = bool(e.rig.keys(sweep)["joint_parents"][key] >= 0)
    _, child, _ = e.rig.key_joint(sweep, key)
    name = e.bone_names[child] if 0 <= child < len(e.bone_names) else ""
    return key_edit.format_key_label(label, key, K, joint_key, name)


class SWEEPDEFORM_UL_corrections(bpy.types.UIList):
    """The key-ellipse corrections: key, angle, mute, delete."""

    def draw_item(self, context, layout, data, item, icon, active_data, active_propname, index):
        obj = data.id_data
        row = layout.row(align=True)
        selected = item.sweep == data.active_sweep and item.key == data.active_key
        row.label(text=key_label(obj, item.sweep, item.key), icon='MESH_CIRCLE' if selected else 'BLANK1')
        sub = row.row(align=True)
        sub.alignment = 'RIGHT'
        sub.label(text=key_edit.degrees(item.angle))
        sub.prop(item, "mute", text="", icon='HIDE_ON' if item.mute else 'HIDE_OFF', emboss=False)
        op = sub.operator(key_operators.OBJECT_OT_sweep_deform_correction_remove.bl_idname, text="", icon='X',
                          emboss=False)
        op.index = index

    def filter_items(self, context, data, propname):
        items = getattr(data, propname)
        flags = []
        for c in items:
            show = not data.list_active_key_only or (c.sweep == data.active_sweep and c.key == data.active_key)
            flags.append(self.bitflag_filter_item if show else 0)
        order = bpy.types.UI_UL_list.sort_items_helper(
            [(i, (c.sweep, c.key, c.angle)) for i, c in enumerate(items)], key=lambda t: t[1])
        return flags, order


def draw_key_editing(layout, context, obj, compact=False):
    s = obj.sweep_deform
    row = layout.row()
    row.scale_y = 1.3
    row.operator(key_operators.OBJECT_OT_sweep_deform_edit_keys.bl_idname, text="Edit Key Ellipses",
                 icon='MESH_CIRCLE', depress=s.edit_keys)
    if s.state != 'BOUND':
        layout.label(text="Bind first", icon='INFO')
        return
    e = deformer_cache.peek(obj)
    col = layout.column(align=True)
    row = col.row(align=True)
    row.prop(s, "active_sweep")
    row.prop(s, "active_key")
    if s.active_sweep >= 0 and s.active_key >= 0:
        col.label(text=key_label(obj, s.active_sweep, s.active_key), icon='MESH_CIRCLE')
        try:
            st = key_ellipses.key_state(obj, s.active_sweep, s.active_key)
        except (RuntimeError, native.NativeError, ValueError, IndexError) as err:
            box = layout.box()
            box.alert = True
            for line in _wrap(str(err)):
                box.label(text=line)
            st = None
        if st is not None:
            col.label(text=f"Joint angle {key_edit.degrees(st['angle'])} (rest {key_edit.degrees(st['rest_angle'])})")
            v = st["values"]
            if not compact:
                col.label(text=f"Correction here: offset {v[0]:+.3f} {v[1]:+.3f} {v[2]:+.3f}, "
                               f"scale {v[6]:.2f} × {v[7]:.2f}")
    else:
        col.label(text="No key ellipse selected: click one in the viewport", icon='INFO')
    if e is not None and e.correction_error:
        _alert_box(layout, e.correction_error, "Corrections refused by the core:")

    layout.label(text=f"Corrections ({len(s.corrections)})")
    row = layout.row()
    row.template_list("SWEEPDEFORM_UL_corrections", "", s, "corrections", s, "active_correction",
                      rows=3 if compact else 4)
    side = row.column(align=True)
    side.operator(key_operators.OBJECT_OT_sweep_deform_correction_remove.bl_idname, text="", icon='REMOVE')
    side.operator(key_operators.OBJECT_OT_sweep_deform_key_clear.bl_idname, text="", icon='TRASH')
    layout.prop(s, "list_active_key_only")
    if 0 <= s.active_correction < len(s.corrections):
        c = s.corrections[s.active_correction]
        box = layout.box()
        box.use_property_split = True
        box.use_property_decorate = True  # keyframe dots: every value can be animated
        box.label(text=key_label(obj, c.sweep, c.key))
        box.prop(c, "angle")
        box.prop(c, "offset")
        box.prop(c, "rotation")
        box.prop(c, "scale_a")
        box.prop(c, "scale_b")
        box.prop(c, "mute")
    col = layout.column()
    col.use_property_split = True
    col.use_property_decorate = False
    col.prop(s, "merge_angle")
    col.prop(s, "show_sweeps", text="Draw Sweeps")


class OBJECT_PT_sweep_deform_keys(_BoundSubPanel, bpy.types.Panel):
    bl_label = "Key Ellipses"

    def draw(self, context):
        draw_key_editing(self.layout, context, context.object)


class VIEW3D_PT_sweep_deform_keys(bpy.types.Panel):
    bl_label = "Key Ellipses"
    bl_space_type = 'VIEW_3D'
    bl_region_type = 'UI'
    bl_category = "Sweep Deform"

    @classmethod
    def poll(cls, context):
        return _bound(context.object)

    def draw(self, context):
        draw_key_editing(self.layout, context, context.object, compact=True)


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


classes = (OBJECT_PT_sweep_deform, OBJECT_PT_sweep_deform_volumes, OBJECT_PT_sweep_deform_anatomy,
           SWEEPDEFORM_UL_corrections,
           OBJECT_PT_sweep_deform_keys, VIEW3D_PT_sweep_deform_keys)


def register():
    for cls in classes:
        bpy.utils.register_class(cls)


def unregister():
    for cls in reversed(classes):
        bpy.utils.unregister_class(cls)
