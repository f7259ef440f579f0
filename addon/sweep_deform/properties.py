# SPDX-License-Identifier: GPL-3.0-or-later
"""Settings and bind state of a character, ``Object.sweep_deform``.

Small values live here (saved with the .blend, restored by undo); the two blobs (the
core's checksummed rig and binding) live in hidden ID properties of the object, see
persistence.py. Changing a setting only marks the character for re-evaluation: the frame
handlers pick the change up.
"""

import bpy
from bpy.props import BoolProperty, EnumProperty, FloatProperty, IntProperty, PointerProperty, StringProperty

STATES = [
    ('UNBOUND', "Not Bound", "No binding: the modifier does nothing"),
    ('BOUND', "Bound", "Bound to the armature; deforms on every pose change"),
    ('REBIND', "Re-bind Needed", "The mesh changed since binding; it is shown undeformed until bound again"),
]


def _settings_changed(self, context):
    # Imported here: runtime imports properties' users, not the other way round.
    from . import runtime
    runtime.settings_changed(self.id_data)


def _is_armature(self, obj):
    return obj.type == 'ARMATURE'


class SweepDeformSettings(bpy.types.PropertyGroup):
    armature: PointerProperty(
        name="Armature", type=bpy.types.Object, poll=_is_armature,
        description="Armature whose pose drives the sweeps (bound to; re-bind after changing it)")
    use_volume_preservation: BoolProperty(
        name="Preserve Volume", default=True, update=_settings_changed,
        description="Scale the sweeps' cross-sections to keep each limb's volume (Sect. 4.4)")
    volume_strength: FloatProperty(
        name="Strength", default=1.0, min=0.0, max=1.0, subtype='FACTOR', update=_settings_changed,
        description="How much of the volume change is corrected (0 = none, 1 = all)")
    show_volumes: BoolProperty(name="Volumes", default=True, description="Show the volume of each limb")

    # Bind state (written by the bind operator; not for editing).
    state: EnumProperty(name="State", items=STATES, default='UNBOUND')
    message: StringProperty(name="Message", description="Why the character is not deforming")
    bind_id: StringProperty(description="Identifies one binding (runtime caches key on it)")
    bone_names: StringProperty(description="JSON list: the rig's bones, in the rig's order")
    library_version: StringProperty(description="libsweepdeform version that made the binding")
    vertex_count: IntProperty()
    edge_count: IntProperty()
    loop_count: IntProperty()
    polygon_count: IntProperty()
    topology: StringProperty(description="SHA-1 of the mesh's connectivity at binding")
    rest_positions: StringProperty(description="SHA-1 of the rest positions at binding")
    sweep_count: IntProperty()
    # The Armature modifier this one replaces, and how it was before we disabled it.
    armature_modifier: StringProperty()
    armature_modifier_viewport: BoolProperty(default=True)
    armature_modifier_render: BoolProperty(default=True)
    armature_modifier_object: PointerProperty(type=bpy.types.Object)


classes = (SweepDeformSettings,)


def register():
    for cls in classes:
        bpy.utils.register_class(cls)
    bpy.types.Object.sweep_deform = PointerProperty(type=SweepDeformSettings)


def unregister():
    del bpy.types.Object.sweep_deform
    for cls in reversed(classes):
        bpy.utils.unregister_class(cls)
