# SPDX-License-Identifier: GPL-3.0-or-later
"""One frame of one character: evaluated pose → core → offsets in the object's carrier.

:func:`evaluate` is what the handlers call for every bound mesh of the scene. It checks that
the character can be deformed (bound, modifier on, object not linked, topology and rest pose
as bound, usable transforms), brings the cache entry's corrections and anatomical effects up
to date, returns at once when the entry's key says this state is already written, and
otherwise makes one call down (``sd_deform_frame``: the deformation, its output check and the
offsets' sums in one pass; or ``sd_deform_with_anatomy``, ``sd_deform_frames``) and writes one
buffer up (the offsets, into the carrier through modifier.write_offsets; the character's
mesh is never written). A frame that cannot be deformed writes nothing: the mesh keeps its
last good deformation and the panel says why.
"""

import math

import numpy as np

from ..core import arrays, checks, native, output_check
from . import anatomy, bind_state, binding, corrections, deformer_cache, mesh_data, modifier, persistence, \
    shape_keys

#: What the user is told after a refused frame, and what happens.
KEPT = "the mesh keeps its last good deformation until this is fixed"


#: Calls into the core for a frame (sd_deform_frame, sd_deform_with_anatomy, ...), all objects together:
#: what the tests count to see that hidden or unchanged characters cost nothing.
core_calls = 0


def linked_mesh_message(obj, md=None):
    """Why a linked object is not deformed (None if the object is local or a library
    override). Its modifier, and the carrier it points at, are library data, which Blender
    does not let an add-on change. A library saved by this version has its Armature modifier
    on and Sweep Deform off (for Blender without the extension, binding.prepare_for_save), so
    the character follows the pose by linear blend skinning here; one saved before shows the
    shape saved in it."""
    lib = obj.library
    if lib is None:
        return None
    md_arm = binding.replaced_armature_modifier(obj)
    by_armature = (md is None or not md.show_viewport) and md_arm is not None and md_arm.show_viewport \
        and md_arm.object is not None
    shown = ("so its Armature modifier deforms it here, as in Blender without the extension" if by_armature
             else "so it shows the shape saved in that file")
    return (f"The object '{obj.name}' is linked from '{lib.filepath}': Sweep Deform cannot change linked data, "
            f"{shown}. To animate it with Sweep Deform here, make a library override of it "
            "(Object > Library Override > Make), or make it local")


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
        except (KeyError, ValueError, IndexError, MemoryError, native.NativeError) as err:
            e.output_check_error = f"{type(err).__name__}: {err}"
            print(f"Sweep Deform: '{obj.name}': frames are not checked: {e.output_check_error}")
    return e.output_check


def _checked_output(e, obj, arm, deformed, pose, depsgraph):
    """(the frame's deformed positions, True: checked and so finite), or, when a vertex ends
    farther from its posed bones than output_check.RATIO_LIMIT times its rest distance (a pose
    the sweeps cannot follow), (the linear blend skinning of the same pose, False); the panel
    then names the frame and the bone."""
    check = _output_check(e, obj, arm)
    if check is None:
        return deformed, False
    try:
        ratio, vertex, bone = check.worst(deformed, pose)  # one parallel pass in the core
    except (ValueError, native.NativeError) as err:  # not expected: the pose passed sd_deform's checks
        e.output_check_error = f"{type(err).__name__}: {err}"
        e.output_check = None
        print(f"Sweep Deform: '{obj.name}': frames are not checked: {e.output_check_error}")
        return deformed, False
    return _judged(e, obj, check, deformed, pose, depsgraph, ratio, vertex, bone)


def _deform_frame(e, obj, arm, pose, moves, whole, depsgraph):
    """The frame in one pass of the core (sd_deform_frame): the deformation (the keys'
    displacements `moves` turned, if any), its output check and the offsets' sums, for a mesh
    in the armature's space. Returns (deformed, turned, composed, checked) as the separate
    steps would give them: when the check refuses the frame, its linear blend skinning, and
    composed None (it is composed again from those)."""
    check = _output_check(e, obj, arm)
    core_check = check.core if check is not None and math.isfinite(output_check.RATIO_LIMIT) else None
    moved, d = moves if moves is not None else (None, None)
    turned = np.empty_like(d) if moves is not None else None
    composed = e.positions_buffer() if whole else e.offsets
    beyond, ratio, vertex, bone = e.deformer.deform_frame(
        pose, moved, d, e.deformer.positions, turned, core_check, output_check.RATIO_LIMIT, e.rest,
        e.mesh_rest(obj) if whole else None, moves is not None and not whole, composed)
    deformed = e.deformer.positions
    if check is None:
        return deformed, turned, composed, False
    if beyond == 0:
        vertex, bone = -1, -1
    checked_positions, checked = _judged(e, obj, check, deformed, pose, depsgraph, float(ratio), vertex, bone)
    return checked_positions, turned, composed if checked_positions is deformed else None, checked


def _judged(e, obj, check, deformed, pose, depsgraph, ratio, vertex, bone):
    """_checked_output's verdict on the check's worst vertex (-1: none beyond the bound)."""
    if vertex < 0:
        e.warning = ""
        return deformed, math.isfinite(output_check.RATIO_LIMIT)
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
    return check.linear_blend(pose, e.fallback), False


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
    if s.state != 'BOUND':
        return False
    if obj.mode == 'EDIT':  # the modifier shows the edits through the offsets carrier
        fall_back_to_offsets(obj, depsgraph=depsgraph)
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
    matrices = (obj_eval.matrix_world.copy(), arm_eval.matrix_world.copy())
    problem = None if matrices == e.matrices_seen else \
        checks.transforms_problem(matrices[0], obj.name, matrices[1], arm.name)
    e.matrices_seen = None if problem else matrices  # the same matrices as last time: as fine as then
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
    # map (not with the anatomical effects, which stay position-based): shape keys alone are
    # turned in the core (their displacement is known here), anything else by the node group
    # from J in the carrier.
    e.mesh_pointer = obj.data.as_pointer()  # its edits reach the entry (handlers._meshes_changed)
    before = modifier.moved_before(obj, md, render)
    keyed = modifier.has_shape_keys(obj)
    with_frames = e.anatomy is None and (before or keyed)
    moves = None  # (the vertices the keys move, their displacements (M,3) mesh space)
    if with_frames and not before:
        mixed = shape_keys.displacements(obj, depsgraph, e.mesh_rest(obj), e.shape_key_buffers())
        if mixed is not None:
            with_frames = False
            moves = e.moving(*mixed, mix=e.shape_key_buffers().mixes)  # None when no key moves anything
    key = (pose.tobytes(), tuple(linear.col[0]) + tuple(linear.col[1]) + tuple(linear.col[2]), settings,
           corrections_key, anatomy_key, with_frames, e.moves_seen if moves is not None else 0)
    # The object's own carriers (made here for a copy of a bound object, a library override or
    # a file bound by an older version; not during a render, which cannot add data). A render
    # writes the render carrier (every render path runs frame_change_post with its depsgraph,
    # F12 included), the viewport its own: neither overwrites what the other reads.
    # In the viewport, with nothing before Sweep Deform that the offsets must ride on, the mesh
    # carrier serves (modifier.py): Blender hands it on instead of sampling offsets.
    whole = (not render and not before and not with_frames and obj.mode == 'OBJECT'
             and not (e.anatomy is not None and keyed))
    n = e.deformer.vertex_count
    count = n * (modifier.FRAME_BLOCKS if with_frames else 1)
    if render:
        targets = [modifier.carrier(obj, md, count, create=False, render=True)]
    else:
        if whole:  # (copied again after an edit, or for another mesh given to the object)
            targets = [modifier.mesh_carrier(obj, md, stale=e.mesh_stale or e.mesh_copied != e.mesh_pointer)]
            e.mesh_stale, e.mesh_copied = False, e.mesh_pointer
        else:
            fall_back_to_offsets(obj, md, depsgraph)
            targets = [modifier.carrier(obj, md, count)]
        made_for = (md.as_pointer(), count)
        if e.render_carrier_for != made_for:  # the render's is made too, for renders to come (once)
            modifier.carrier(obj, md, count, create=True, render=True)
            if whole:  # and the viewport's own offsets carrier, for when the mesh carrier cannot serve
                modifier.carrier(obj, md, count)
            e.render_carrier_for = made_for
    if any(c is None for c, _ in targets):
        e.refuse(obj, "Sweep Deform has no place for this object's deformation yet: it is made at the next "
                      f"update in the viewport; {KEPT}")
        return False
    if key == e.refused_key or all(not fresh and e.written.get(c.name) == key for c, fresh in targets):
        return False  # already written (a new carrier is written again), or refused
    if whole and e.written.get(targets[0][0].name) == key:  # the mesh copied again: the same positions
        modifier.write_offsets(targets[0][0], e.positions_buffer())
        return False
    if settings != e.settings:
        e.deformer.set_volume_preservation(*settings)
        e.settings = settings
    global core_calls
    core_calls += 1
    composed = None  # the offsets (whole: positions) when the core's pass made them
    checked = None  # whether the frame was checked, once it was
    if moves is not None:
        moved, d = moves
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
        elif to_mesh is None:  # the deformation, its check and the sums below in one pass, to the bit
            deformed, turned, composed, checked = _deform_frame(e, obj, arm, pose, moves, whole, depsgraph)
        elif moves is not None:
            d_armature = np.matmul(d, np.asarray(linear, np.float32).T)
            deformed, turned = e.deformer.deform_displaced(pose, moved, d_armature, e.deformer.positions,
                                                           np.empty_like(d))
        else:
            deformed = e.deformer.deform(pose)
    except native.NativeError as err:
        why = checks.name_bones(str(err), e.bone_names) + _bad_channels(arm_eval)
        e.refuse(obj, f"Unusable pose: {why}: {KEPT}")
        e.refused_key = key
        return False
    if checked is None:  # (the core's one pass checked it already)
        deformed, checked = _checked_output(e, obj, arm, deformed, pose, depsgraph)
    if whole:
        e.whole_moves = e.moves_copy() if moves is not None else None  # (a render may mix other values)
    if composed is not None:
        offsets = composed
    elif to_mesh is None:  # the sums below in one pass of the core, to the bit
        offsets = native.compose_offsets(deformed, e.rest, e.mesh_rest(obj) if whole else None,
                                         moved if moves is not None else None,
                                         turned if moves is not None else None,
                                         d if moves is not None and not whole else None,
                                         e.positions_buffer() if whole else e.offsets)
    else:
        offsets = arrays.offsets_into(deformed, e.rest, to_mesh, e.offsets, e.scratch)
        if whole:  # the deformed positions: the mesh + offsets, and the keys' displacements turned
            offsets = np.add(e.mesh_rest(obj), offsets, out=e.positions_buffer())
        if moves is not None:  # the keys' turned displacements: + J d (positions), + (J - I) d (offsets)
            change = turned @ to_mesh
            if not whole:
                change -= d
            if len(moved) == len(offsets):
                offsets += change  # every vertex: no scatter
            else:
                arrays.add_to_rows(offsets, e.moved_flat, change)
    if frames is not None:  # the carrier's blocks: offsets, J - I (mesh space), rest (in place)
        packed[:n] = offsets
        arrays.pack_frames(frames, linear, to_mesh)
        offsets = packed
    # Finite already when the check passed the frame (a non-finite vertex is beyond it) and
    # nothing maps it; else, e.g. a nearly flat object whose inverse overflows, look.
    if not (checked and to_mesh is None) and not np.isfinite(offsets).all():
        e.refuse(obj, f"The deformation of '{obj.name}' is not finite here: {KEPT}")
        e.refused_key = key
        if whole:  # its positions' buffer no longer holds what the mesh carrier shows
            e.written.pop(targets[0][0].name, None)
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


def fall_back_to_offsets(obj, md=None, depsgraph=None):
    """When the object's mesh carrier holds a mesh: the viewport's offsets carrier is given the
    deformation it shows (its positions less what reaches the modifier: the mesh, and the
    shape keys' displacements), then the mesh carrier is emptied, so the offsets carrier serves
    with no change to be seen. Before a save (files keep the offsets, not a copy of the mesh),
    in Edit Mode and a paint mode, and with a modifier before Sweep Deform. Returns True if the
    mesh carrier was in use."""
    md = md or modifier.find(obj)
    c = modifier.mesh_carrier_in_use(obj, md)
    if c is None:
        return False
    e = deformer_cache.peek(obj)
    if e is None:
        _fall_back(obj, md, c, None, depsgraph)
    else:
        with e.lock:  # (a render thread may be evaluating the same entry: see evaluate())
            _fall_back(obj, md, c, e, depsgraph)
    return True


def _fall_back(obj, md, c, e, depsgraph):
    """fall_back_to_offsets for the mesh carrier `c` in use, with the object's cache entry `e`
    held (None: no entry in memory). Carriers are emptied on the main thread only, as here."""
    n = len(c.data.vertices)
    offsets = np.empty(3 * n, np.float32)
    c.data.attributes['position'].data.foreach_get('vector', offsets)
    offsets = offsets.reshape(-1, 3)
    rest = e.mesh_rest(obj) if e is not None else mesh_data.vertex_positions(obj.data)
    if len(rest) == n:
        offsets -= rest
        moves = e.whole_moves if e is not None else None
        if moves is None and modifier.has_shape_keys(obj) and depsgraph is not None:
            mixed = shape_keys.displacements(obj, depsgraph, rest, shape_keys.ShapeKeyBuffers(n))
            moves = mixed if mixed is not None and mixed[0].size else None
        if moves is not None:
            offsets[moves[0]] -= moves[1]
        target, _ = modifier.carrier(obj, md, n)
        if target is not None:
            modifier.write_offsets(target, offsets)
            if e is not None:
                e.written[target.name] = e.written.get(c.name)
    if e is not None:
        e.written.pop(c.name, None)
    modifier.empty_mesh_carrier(obj, md)
