# SPDX-License-Identifier: GPL-3.0-or-later
"""Settings and bind state of a character, ``Object.sweep_deform``.

Small values live here (saved with the .blend, restored by undo); the two blobs (the
core's checksummed rig and binding) live in hidden ID properties of the object, see
persistence.py. Changing a setting only marks the character for re-evaluation: the frame
handlers pick the change up.
"""

import math

import bpy
from bpy.props import (BoolProperty, CollectionProperty, EnumProperty, FloatProperty, FloatVectorProperty,
                       IntProperty, PointerProperty, StringProperty)

from . import anatomy, corrections, deformer_cache, redraw

STATES = [
    ('UNBOUND', "Not Bound", "No binding: the modifier does nothing"),
    ('BOUND', "Bound", "Bound to the armature; deforms on every pose change"),
    ('REBIND', "Re-bind Needed", "The mesh changed since binding; it is shown undeformed until bound again"),
]


def _settings_changed(self, context):
    deformer_cache.settings_changed(self.id_data)


def _is_armature(self, obj):
    return obj.type == 'ARMATURE'


def _corrections_changed(self, context):
    # The handlers read the corrections on every evaluation; this only asks for one.
    corrections.corrections_changed(self.id_data)


def _edit_changed(self, context):
    redraw.redraw_views()


class SweepDeformCorrection(bpy.types.PropertyGroup):
    """A pose-space correction of one key ellipse (Sect. 4.2): made while the key's joint
    stood at `angle`; its values are interpolated over the joint angle by the core. Every
    value is an ordinary property: it can be keyframed or driven."""
    sweep: IntProperty(name="Sweep", min=0, description="Index of the sweep (limb) of the key ellipse")
    key: IntProperty(name="Key", min=0, description="Index of the key ellipse along its sweep")
    angle: FloatProperty(
        name="Angle", subtype='ANGLE', min=0.0, max=math.pi, update=_corrections_changed,
        description="Joint angle this correction belongs to (the angle between the joint's two links)")
    offset: FloatVectorProperty(
        name="Offset", size=3, subtype='TRANSLATION', unit='LENGTH', update=_corrections_changed,
        description="Move of the ellipse's center along its own axes (major, minor, normal)")
    rotation: FloatVectorProperty(
        name="Rotation", size=3, subtype='XYZ', unit='ROTATION', soft_min=-math.pi / 2, soft_max=math.pi / 2,
        update=_corrections_changed,
        description="Turn of the ellipse about its own axes (a rotation vector: axis times angle, at most 90°)")
    scale_a: FloatProperty(
        name="Scale A", default=1.0, min=0.1, max=10.0, soft_min=0.25, soft_max=4.0, update=_corrections_changed,
        description="Factor of the half-axis a (along the major axis)")
    scale_b: FloatProperty(
        name="Scale B", default=1.0, min=0.1, max=10.0, soft_min=0.25, soft_max=4.0, update=_corrections_changed,
        description="Factor of the half-axis b (along the minor axis)")
    mute: BoolProperty(name="Mute", default=False, update=_corrections_changed,
                       description="Keep the correction but do not use it")


def _anatomy_toggled(self, context):
    # A character bound before the anatomical effects existed gets its joints now.
    if self.use_anatomy and len(self.joints) == 0:
        anatomy.fill_joints(self.id_data)
    deformer_cache.settings_changed(self.id_data)


JOINT_KINDS = [
    ('ELBOW', "Elbow", "An elbow: olecranon proxy on the forearm, biceps bulge"),
    ('KNEE', "Knee", "A knee: patella proxy on the shin, calf bulge"),
]


class SweepDeformJoint(bpy.types.PropertyGroup):
    """The anatomical effects of one joint (Sect. 4.3, 4.4), found from the fitting report's
    arm and leg chains at binding. `name` is what the panel shows ("Elbow L")."""
    bone: StringProperty(name="Bone", description="The joint's lower bone (forearm, shin)")
    kind: EnumProperty(name="Kind", items=JOINT_KINDS, default='ELBOW')
    flexion_direction: FloatVectorProperty(
        name="Flexion Direction", size=3, default=(0.0, -1.0, 0.0),
        description="Where the lower bone moves when the joint flexes (armature space, rest)")
    use_folding: BoolProperty(name="Folding", default=True, update=_settings_changed,
                              description="Fold the skin where it would pass through itself at this joint")
    use_protrusion: BoolProperty(name="Protrusion", default=True, update=_settings_changed,
                                 description="Let the bone (olecranon, patella) show through the skin")
    use_bulge: BoolProperty(name="Bulge", default=True, update=_settings_changed,
                            description="Bulge the muscle (biceps, calf) as the joint flexes")
    protrusion_strength: FloatProperty(
        name="Protrusion Strength", default=1.0, min=0.0, max=2.0, update=_settings_changed,
        description="Scales the push of the skin out of the bone proxy")
    bulge_strength: FloatProperty(
        name="Bulge Strength", default=0.15, min=0.0, max=1.0, subtype='FACTOR', update=_settings_changed,
        description="Outward push of the muscle at full flexion, as a share of the limb's local radius")


class SweepDeformSettings(bpy.types.PropertyGroup):
    # The object pointers are LIBRARY_OVERRIDABLE (and so is Object.sweep_deform, below): in a
    # library override they then point at the overrides of the hierarchy after a reload too.
    # Without it a reopened file got them back from the library: the linked armature, in no
    # scene and never posed (test_library.py::test_library_override_deforms).
    armature: PointerProperty(
        name="Armature", type=bpy.types.Object, poll=_is_armature, override={'LIBRARY_OVERRIDABLE'},
        description="Armature whose pose drives the sweeps (bound to; re-bind after changing it)")
    use_volume_preservation: BoolProperty(
        name="Preserve Volume", default=True, update=_settings_changed,
        description="Scale the sweeps' cross-sections to keep each limb's volume (Sect. 4.4)")
    volume_strength: FloatProperty(
        name="Strength", default=1.0, min=0.0, max=1.0, subtype='FACTOR', update=_settings_changed,
        description="How much of the volume change is corrected (0 = none, 1 = all)")
    show_volumes: BoolProperty(name="Volumes", default=True, description="Show the volume of each limb")

    # Anatomical effects (Sect. 4.3, 4.4): off by default; per joint below.
    use_anatomy: BoolProperty(
        name="Anatomical Effects", default=False, update=_anatomy_toggled,
        description="Skin folding, bone protrusion and muscle bulge at the elbows and knees, with the volume "
                    "they add taken out of the volume control's target")
    joints: CollectionProperty(type=SweepDeformJoint, name="Joints")

    # Key-ellipse editing (Sect. 4.2): the corrections, and the editing state.
    corrections: CollectionProperty(type=SweepDeformCorrection, name="Corrections")
    active_correction: IntProperty(name="Active Correction", default=0, min=0)
    edit_keys: BoolProperty(
        name="Edit Key Ellipses", default=False, update=_edit_changed,
        description="Show the key ellipses and sweeps in the viewport, with gizmos on the selected key")
    active_sweep: IntProperty(name="Sweep", default=-1, min=-1, update=_edit_changed,
                              description="Sweep of the selected key ellipse (-1: none)")
    active_key: IntProperty(name="Key", default=-1, min=-1, update=_edit_changed,
                            description="The selected key ellipse along its sweep (-1: none)")
    merge_angle: FloatProperty(
        name="Merge Angle", subtype='ANGLE', default=math.radians(5.0), min=0.0, max=math.radians(45.0),
        description="An edit this close to a correction's angle edits that correction; this close to the rest "
                    "angle it is an edit at rest (it shifts every pose)")
    show_sweeps: BoolProperty(name="Sweeps", default=True, update=_edit_changed,
                              description="Draw the sweep surfaces as a wireframe")
    list_active_key_only: BoolProperty(name="Selected Key Only", default=False,
                                       description="List only the corrections of the selected key ellipse")

    # Bind state (written by the bind operator; not for editing).
    state: EnumProperty(name="State", items=STATES, default='UNBOUND')
    message: StringProperty(name="Message", description="Why the character is not deforming")
    bind_id: StringProperty(description="Identifies one binding (the deformer cache keys on it)")
    bone_names: StringProperty(description="JSON list: the rig's bones, in the rig's order")
    library_version: StringProperty(description="libsweepdeform version that made the binding")
    vertex_count: IntProperty()
    edge_count: IntProperty()
    loop_count: IntProperty()
    polygon_count: IntProperty()
    topology: StringProperty(description="SHA-1 of the mesh's connectivity at binding")
    rest_positions: StringProperty(description="SHA-1 of the rest positions at binding")
    sweep_count: IntProperty()
    # What the binding was made with, for the messages when it is gone (issue 15).
    bound_armature: StringProperty(description="Name of the armature object at binding")
    bound_armature_data: StringProperty(description="Name of the armature's data at binding")
    bound_armature_object: PointerProperty(type=bpy.types.Object, description="The armature at binding",
                                           override={'LIBRARY_OVERRIDABLE'})
    # The Armature modifier this one replaces, and how it was before we disabled it.
    armature_modifier: StringProperty()
    armature_modifier_viewport: BoolProperty(default=True)
    armature_modifier_render: BoolProperty(default=True)
    armature_modifier_object: PointerProperty(type=bpy.types.Object, override={'LIBRARY_OVERRIDABLE'})
    # While it is off, its Vertex Groups and Bone Envelopes are unticked (a switched-off
    # Armature modifier still makes every pose change evaluate the mesh): the artist's values,
    # given back whenever it is on (binding.sync_replaced_modifier).
    armature_modifier_inputs_kept: BoolProperty(default=False)
    armature_modifier_vertex_groups: BoolProperty(default=True)
    armature_modifier_envelopes: BoolProperty(default=False)
    # A file saved while bound has the Armature modifier on and Sweep Deform off, for Blender
    # without the extension (binding.prepare_for_save); the extension restores these on load.
    saved_for_blender_without_extension: BoolProperty(default=False)
    sweep_modifier_viewport: BoolProperty(default=True)
    sweep_modifier_render: BoolProperty(default=True)


classes = (SweepDeformCorrection, SweepDeformJoint, SweepDeformSettings)


def register():
    for cls in classes:
        bpy.utils.register_class(cls)
    bpy.types.Object.sweep_deform = PointerProperty(type=SweepDeformSettings, override={'LIBRARY_OVERRIDABLE'})


def unregister():
    del bpy.types.Object.sweep_deform
    for cls in reversed(classes):
        bpy.utils.unregister_class(cls)
