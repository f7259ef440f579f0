# SPDX-License-Identifier: GPL-3.0-or-later
"""One frame of one character: evaluated pose → core → offsets in the object's carrier.

:func:`evaluate` is what the handlers call for every bound mesh of the scene. It checks that
the character can be deformed (bound, modifier on, object not linked, topology and rest pose
as bound, usable transforms), brings the cache entry's corrections and anatomical effects up
to date, returns at once when the entry's key says this state is already written, and
otherwise makes one call down (``sd_deform`` or ``sd_deform_with_anatomy``) and writes one
buffer up (the offsets, into the carrier through modifier.write_offsets; the character's
mesh is never written). A frame that cannot be deformed writes nothing: the mesh keeps its
last good deformation and the panel says why.
"""

import numpy as np

from ..core import arrays, checks, native
from . import anatomy, bind_state, corrections, deformer_cache, modifier, persistence

#: What the user is told after a refused frame, and what happens.
KEPT = "the mesh keeps its last good deformation until this is fixed"


#: Calls into the core for a frame (sd_deform or sd_deform_with_anatomy), all objects together:
#: what the tests count to see that hidden or unchanged characters cost nothing.
core_calls = 0


def linked_mesh_message(obj):
    """Why a linked object is not deformed (None if the object is local or a library
    override). Its modifier, and the carrier it points at, are library data, which Blender
    does not let an add-on change, so it shows the shape saved in that file."""
    lib = obj.library
    if lib is None:
        return None
    return (f"The object '{obj.name}' is linked from '{lib.filepath}': Sweep Deform cannot change linked data, "
            "so it shows the shape saved in that file. To animate it here, make a library override of it "
            "(Object > Library Override > Make), or make it local")


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
    if not modifier.active(md, render):
        return False
    arm = s.armature
    if arm is None or arm.mode == 'EDIT':
        return False
    linked = linked_mesh_message(obj)
    if linked:
        deformer_cache.entry(obj).refuse(obj, linked)
        return False
    if not persistence.counts_match(obj):
        bind_state.set_rebind(obj, "The mesh's topology changed after binding: bind again")
        return False
    e = deformer_cache.entry(obj)
    # A render thread (Lock Interface off) and the viewport may evaluate the same character at
    # once: the entry's buffers (pose, offsets, the deformer's output) serve one at a time.
    with e.lock:
        return _evaluate_entry(obj, s, md, arm, e, depsgraph, render)


def _evaluate_entry(obj, s, md, arm, e, depsgraph, render):
    if e.deformer is None:
        if e.unusable:
            bind_state.set_rebind(obj, f"The stored binding cannot be used ({e.load_error}): bind again")
        return False
    if not e.rest_checked:
        e.rest_checked = True
        if not e.rest_pose_matches(arm):
            bind_state.set_rebind(obj, f"The rest pose of '{arm.name}' changed after binding: bind again")
            return False
    arm_eval = arm.evaluated_get(depsgraph)
    obj_eval = obj.evaluated_get(depsgraph)
    try:
        pose = e.armature_pose(arm_eval)
    except KeyError as err:
        bind_state.set_rebind(obj, f"{err.args[0]}: bind again")
        return False
    problem = checks.transforms_problem(obj_eval.matrix_world, obj.name, arm_eval.matrix_world, arm.name)
    if problem:
        e.refuse(obj, f"{problem}: {KEPT}")
        e.forget_writes()
        return False
    # Offsets are vectors: only the linear part of mesh → armature space maps them back.
    try:
        linear = (arm_eval.matrix_world.inverted() @ obj_eval.matrix_world).to_3x3()
        to_mesh = e.to_mesh_space(linear)
    except (ValueError, np.linalg.LinAlgError):  # flat in float32 though not quite in float64
        e.refuse(obj, f"The object '{obj.name}' or its armature has a zero scale: {KEPT}")
        e.forget_writes()
        return False
    settings = (bool(s.use_volume_preservation), float(s.volume_strength))
    # Corrections: in the viewport from the object itself (Blender copies animated and driven
    # values back to it for the active depsgraph, and a removed item is seen at once); in a
    # render from the render depsgraph's copy, which holds that frame's animated values.
    corrections_key = corrections.sync_corrections(e, obj_eval.sweep_deform if render else s)
    anatomy_key = anatomy.sync_anatomy(e, obj, obj_eval.sweep_deform if render else s)
    # Shape keys or modifiers before Sweep Deform ride along through each vertex's local linear
    # map (not with the anatomical effects, which stay position-based).
    with_frames = e.anatomy is None and modifier.needs_frames(obj, md, render)
    key = (pose.tobytes(), tuple(linear.col[0]) + tuple(linear.col[1]) + tuple(linear.col[2]), settings,
           corrections_key, anatomy_key, with_frames)
    # The object's own carriers (made here for a copy of a bound object, a library override or
    # a file bound by an older version; not during a render, which cannot add data). A render
    # writes the render carrier (every render path runs frame_change_post with its depsgraph,
    # F12 included), the viewport its own: neither overwrites what the other reads.
    n = e.deformer.vertex_count
    count = n * (modifier.FRAME_BLOCKS if with_frames else 1)
    if render:
        targets = [modifier.carrier(obj, md, count, create=False, render=True)]
    else:
        targets = modifier.carriers(obj, md, count)[:1]  # the render's is made too, for renders to come
    if any(c is None for c, _ in targets):
        e.refuse(obj, "Sweep Deform has no place for this object's deformation yet: it is made at the next "
                      f"update in the viewport; {KEPT}")
        return False
    if key == e.refused_key or all(not fresh and e.written.get(c.name) == key for c, fresh in targets):
        return False  # already written (a new carrier is written again), or refused
    if settings != e.settings:
        e.deformer.set_volume_preservation(*settings)
        e.settings = settings
    global core_calls
    core_calls += 1
    try:
        frames = None
        if e.anatomy is not None:
            deformed = e.anatomy.deform(e.deformer, pose)
            e.anatomy_stats = e.anatomy.stats()
        elif with_frames:
            # J straight into the carrier's blocks 1..3 (no copy)
            packed = e.packed_buffer(obj)
            frames = packed[n:4 * n].reshape(3, n, 3)
            deformed, _ = e.deformer.deform_frames(pose, e.deformer.positions, frames)
        else:
            deformed = e.deformer.deform(pose)
    except native.NativeError as err:
        e.refuse(obj, f"Unusable pose: {checks.name_bones(str(err), e.bone_names)}: {KEPT}")
        e.refused_key = key
        return False
    offsets = arrays.offsets_into(deformed, e.rest, to_mesh, e.offsets, e.scratch)
    if frames is not None:  # the carrier's blocks: offsets, J - I (mesh space), rest (in place)
        packed[:n] = offsets
        arrays.pack_frames(frames, linear, to_mesh)
        offsets = packed
    if not np.isfinite(offsets).all():  # e.g. a nearly flat object whose inverse overflows
        e.refuse(obj, f"The deformation of '{obj.name}' is not finite here: {KEPT}")
        e.refused_key = key
        return False
    for c, _ in targets:
        modifier.write_offsets(c, offsets)
        e.written[c.name] = key
    if not render:
        e.last_pose = pose.copy()  # the overlay and key edits follow the pose the viewport shows
    e.refused_key = None
    e.error = ""
    e.frames += 1
    return True
