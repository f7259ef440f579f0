# SPDX-License-Identifier: GPL-3.0-or-later
"""One frame of one character: evaluated pose → core → offsets in the mesh's attribute.

:func:`evaluate` is what the handlers call for every bound mesh of the scene. It checks that
the character can be deformed (bound, modifier on, not linked, topology and rest pose as
bound, usable transforms), brings the cache entry's corrections and anatomical effects up to
date, returns at once when the entry's key says this state is already written, and otherwise
makes one call down (``sd_deform`` or ``sd_deform_with_anatomy``) and writes one buffer up
(the offsets, through modifier.write_offsets). A frame that cannot be deformed writes nothing:
the mesh keeps its last good deformation and the panel says why.
"""

import numpy as np

from ..core import arrays, checks, native, output_check
from . import anatomy, bind_state, binding, corrections, deformer_cache, modifier, persistence

#: What the user is told after a refused frame, and what happens.
KEPT = "the mesh keeps its last good deformation until this is fixed"


def linked_mesh_message(obj, md=None):
    """Why a linked mesh is not deformed by Sweep Deform (None if the mesh is local). Blender
    ignores an add-on's writes into library data, so the offsets cannot go into it. A library
    saved by this version has its Armature modifier on and Sweep Deform off (for Blender
    without the extension, binding.prepare_for_save), so the character follows the pose by
    linear blend skinning here; one saved before shows the shape saved in it."""
    lib = obj.data.library
    if lib is None:
        return None
    md_arm = binding.replaced_armature_modifier(obj)
    by_armature = (md is None or not md.show_viewport) and md_arm is not None and md_arm.show_viewport \
        and md_arm.object is not None
    shown = ("so its Armature modifier deforms it here, as in Blender without the extension" if by_armature
             else "so it shows the shape saved in that file")
    return (f"The mesh '{obj.data.name}' is linked from '{lib.filepath}': Sweep Deform cannot write its "
            f"deformation into linked data, {shown}. To animate it with Sweep Deform here, make "
            "it local (Object > Relations > Make Local > Selected Objects and Data), or a library override "
            "of it first")


def armature_problem(obj):
    """None while the binding's armature is there, else what happened to it, naming it: deleted
    (the pointer went empty, or the object is in no scene any more), or replaced by another
    armature object."""
    s = obj.sweep_deform
    arm = s.armature
    if arm is None:
        name = f" '{s.bound_armature}'" if s.bound_armature else ""
        return f"The armature{name} this mesh was bound to was deleted (or cleared from the Sweep Deform settings)"
    if not arm.users_scene:  # deleted by the operator: kept alive only by references like ours
        return f"The armature '{arm.name}' this mesh was bound to was deleted (it is in no scene any more)"
    original = s.bound_armature_object
    if original is not None and original != arm:
        return f"The armature was replaced ('{original.name}' when bound, '{arm.name}' now)"
    return None


def _rest_message(obj, arm, problem):
    """The panel's message for changed bones or rest pose; it also says when the armature's
    data is another one than at binding (a renamed data block with the same bones is fine)."""
    data = obj.sweep_deform.bound_armature_data
    if data and arm.data is not None and arm.data.name != data:
        problem = (f"the armature data of '{arm.name}' was replaced ('{data}' when bound, '{arm.data.name}' now): "
                   f"{problem}")
    return f"{problem[0].upper()}{problem[1:]}: bind again"


def _output_check(e, obj, arm):
    """The entry's OutputCheck, made on first use from the vertex groups (None, with the
    reason in e.output_check_error, if it cannot be made)."""
    if e.output_check is None and not e.output_check_error:
        try:
            ids, weights = binding.skin_weights(obj, arm, e.bone_names)
            lengths = np.array([arm.data.bones[n].length for n in e.bone_names], np.float64)
            e.output_check = output_check.OutputCheck(e.rest, e.rest_pose, lengths, ids, weights)
        except (KeyError, ValueError, IndexError, MemoryError) as err:
            e.output_check_error = f"{type(err).__name__}: {err}"
            print(f"Sweep Deform: '{obj.name}': frames are not checked: {e.output_check_error}")
    return e.output_check


def _checked_output(e, obj, arm, deformed, pose, depsgraph):
    """The frame's deformed positions, or, when a vertex ends farther from its posed bones than
    output_check.RATIO_LIMIT times its rest distance (a pose the sweeps cannot follow), the
    linear blend skinning of the same pose; the panel then names the frame and the bone."""
    check = _output_check(e, obj, arm)
    if check is None:
        return deformed
    ratio, vertex, bone = check.worst(deformed, pose)
    if ratio <= output_check.RATIO_LIMIT:
        e.warning = ""
        return deformed
    frame = depsgraph.scene.frame_current if depsgraph is not None and depsgraph.scene else None
    name = e.bone_names[bone] if 0 <= bone < len(e.bone_names) else f"bone {bone}"
    shown = "inf" if not np.isfinite(ratio) else f"{ratio:.1f}"
    message = (f"Frame {frame}: pose beyond what the sweeps can follow (vertex {vertex} is {shown}× its rest "
               f"distance from '{name}', limit {output_check.RATIO_LIMIT:g}×): shown with linear blend skinning")
    if message != e.warning:
        print(f"Sweep Deform: '{obj.name}': {message}")
    e.warning = message
    e.fallback_frames += 1
    if e.fallback is None:
        e.fallback = np.empty_like(e.rest)
    return check.linear_blend(pose, e.fallback)


def _bad_channels(arm_eval):
    """" (bone 'x': its rotation_quaternion is NaN)" for the pose channels that are not finite
    (Blender turns a NaN quaternion into a zero matrix, which the core can only call
    degenerate), or ""."""
    found = []
    for pb in arm_eval.pose.bones:
        for channel in ("location", "rotation_quaternion", "rotation_euler", "rotation_axis_angle", "scale"):
            values = tuple(getattr(pb, channel))
            if not all(np.isfinite(values)):
                found.append(f"bone '{pb.name}': its {channel} is {'NaN' if any(np.isnan(values)) else 'infinite'}")
    return f" ({'; '.join(found[:3])})" if found else ""


def evaluate(obj, depsgraph, render=False):
    """Updates the offsets of one bound mesh object for the pose in `depsgraph`.
    Returns True if it wrote new offsets."""
    s = obj.sweep_deform
    if s.state != 'BOUND' or obj.mode == 'EDIT':
        return False
    md = modifier.find(obj)
    if md is None:
        bind_state.modifier_gone(obj)
        return False
    linked = linked_mesh_message(obj, md)
    if linked:
        deformer_cache.entry(obj).refuse(obj, linked)
        return False
    if not modifier.active(md, render):
        return False
    arm = s.armature
    gone = armature_problem(obj)
    if gone:
        bind_state.set_rebind(obj, f"{gone}: bind again")
        return False
    if arm.mode == 'EDIT':
        return False
    if obj.data.users > 1:
        bind_state.set_rebind(obj, f"The mesh '{obj.data.name}' is used by several objects: make it single "
                                   "user and bind again")
        return False
    if not persistence.counts_match(obj):
        bind_state.set_rebind(obj, "The mesh's topology changed after binding: bind again")
        return False
    e = deformer_cache.entry(obj)
    if e.deformer is None:
        if e.unusable:
            bind_state.set_rebind(obj, f"The stored binding cannot be used ({e.load_error}): bind again")
        return False
    seen = (len(arm.data.bones), arm.data.name)  # a bone removed, other data: check again
    if not e.rest_checked or e.armature_seen != seen:
        e.rest_checked = True
        e.armature_seen = seen
        problem = e.rest_pose_problem(arm)
        if problem:
            bind_state.set_rebind(obj, _rest_message(obj, arm, problem))
            return False
    arm_eval = arm.evaluated_get(depsgraph)
    obj_eval = obj.evaluated_get(depsgraph)
    try:
        pose = e.armature_pose(arm_eval)
    except KeyError as err:
        bind_state.set_rebind(obj, _rest_message(obj, arm, e.rest_pose_problem(arm) or err.args[0]))
        return False
    problem = checks.transforms_problem(obj_eval.matrix_world, obj.name, arm_eval.matrix_world, arm.name)
    if problem:
        e.refuse(obj, f"{problem}: {KEPT}")
        e.key = None
        return False
    # Offsets are vectors: only the linear part of mesh → armature space maps them back.
    try:
        linear = (arm_eval.matrix_world.inverted() @ obj_eval.matrix_world).to_3x3()
        to_mesh = e.to_mesh_space(linear)
    except (ValueError, np.linalg.LinAlgError):  # flat in float32 though not quite in float64
        e.refuse(obj, f"The object '{obj.name}' or its armature has a zero scale: {KEPT}")
        e.key = None
        return False
    settings = (bool(s.use_volume_preservation), float(s.volume_strength))
    # Corrections: in the viewport from the object itself (Blender copies animated and driven
    # values back to it for the active depsgraph, and a removed item is seen at once); in a
    # render from the render depsgraph's copy, which holds that frame's animated values.
    corrections_key = corrections.sync_corrections(e, obj_eval.sweep_deform if render else s)
    anatomy_key = anatomy.sync_anatomy(e, obj, obj_eval.sweep_deform if render else s)
    key = (pose.tobytes(), tuple(linear.col[0]) + tuple(linear.col[1]) + tuple(linear.col[2]), settings,
           corrections_key, anatomy_key)
    if key == e.key and arrays.OFFSET_ATTRIBUTE in obj.data.attributes:
        return False  # already written (an attribute removed by someone else is written again)
    if settings != e.settings:
        e.deformer.set_volume_preservation(*settings)
        e.settings = settings
    try:
        if e.anatomy is not None:
            deformed = e.anatomy.deform(e.deformer, pose)
            e.anatomy_stats = e.anatomy.stats()
        else:
            deformed = e.deformer.deform(pose)
    except native.NativeError as err:
        why = checks.name_bones(str(err), e.bone_names) + _bad_channels(arm_eval)
        e.refuse(obj, f"Unusable pose: {why}: {KEPT}")
        e.key = key
        return False
    deformed = _checked_output(e, obj, arm, deformed, pose, depsgraph)
    offsets = arrays.offsets_into(deformed, e.rest, to_mesh, e.offsets, e.scratch)
    if not np.isfinite(offsets).all():  # e.g. a nearly flat object whose inverse overflows
        e.refuse(obj, f"The deformation of '{obj.name}' is not finite here: {KEPT}")
        e.key = key
        return False
    modifier.write_offsets(obj.data, offsets)
    e.last_pose = pose.copy()  # the overlay and key edits follow the pose the mesh shows
    e.key = key
    e.error = ""
    e.frames += 1
    return True
