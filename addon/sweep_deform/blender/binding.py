# SPDX-License-Identifier: GPL-3.0-or-later
"""Binding a mesh to an armature, in stages the bind operator can report and cancel between.

    read     (main thread)  mesh, triangles, skeleton, skin weights → numpy, armature space
    fit      (worker)       sd_fit_rig: key ellipses on the mesh, per-vertex sweep/bone weights
    bind     (worker)       sd_bind: t, θ and displacement of every vertex
    store    (main thread)  blobs into the object, modifier in the stack, Armature modifier off

The two native stages take only numpy arrays and run outside the main thread (ctypes releases
the GIL), so the interface keeps drawing the progress and Esc is seen; a cancelled job's
result is dropped and nothing in the file changes until ``store``.

``fitter`` is the function that makes the rig: :func:`fit_native` (the core's automatic
fitting). Tests may replace it with a rig of their own; the product has no other path.
"""

import uuid

import bpy
import numpy as np

from ..core import arrays, checks, fit_report, native
from . import anatomy, deformer_cache, mesh_data, modifier, persistence

#: Influences per vertex read from the vertex groups for the fitting.
SKIN_SLOTS = 8


class BindError(RuntimeError):
    pass


def bind_errors():
    """Every error binding can raise on bad input or a bad installation: the add-on's own
    (BindError), the native layer's (NativeError, NativeLibraryError), the numpy and
    ctypes layers' (ValueError, LinAlgError, ArithmeticError, KeyError, IndexError) and a mesh
    too big for memory (MemoryError).
    The operators turn each into a report in the interface (one path, ui/bind_operators.py)."""
    return (BindError, native.NativeError, native.NativeLibraryError, ValueError, ArithmeticError,
            MemoryError, KeyError, IndexError, np.linalg.LinAlgError)


def error_message(e):
    """The report for a bind error: BindError's text as is, others with the kind of failure."""
    if isinstance(e, BindError):
        return str(e)
    if isinstance(e, native.NativeLibraryError):
        return f"the native library cannot be used: {e}"
    if isinstance(e, native.NativeError):
        return f"the core refused the character: {e}"
    if isinstance(e, MemoryError):
        return "not enough memory to bind this mesh"
    return f"{type(e).__name__}: {e}"


class BindInputs:
    """Everything the native stages need, as numpy arrays in armature space."""

    def __init__(self):
        self.object_name = ""
        self.armature_name = ""
        self.mesh_to_armature = None  # 4x4 row-major (Blender Matrix as list)
        self.positions = None         # (V,3) float32, armature space
        self.triangles = None         # (T,3) int32
        self.bone_names = []
        self.parents = self.rest = self.heads = self.tails = None
        self.skin_bones = self.skin_weights = None  # (V,SKIN_SLOTS)


class BindOutputs:
    def __init__(self, rig, rig_blob, binding, report=""):
        self.rig, self.rig_blob, self.binding, self.report = rig, rig_blob, binding, report


# ---- finding the armature ----------------------------------------------------------------


def find_armature(obj, name=""):
    """The armature that drives `obj`: by `name`, else its (first) Armature modifier's
    object, else its parent if that is an armature. None if there is none."""
    if name:
        arm = bpy.data.objects.get(name)
        if arm is None or arm.type != 'ARMATURE':
            raise BindError(f"No armature object named '{name}'")
        return arm
    if obj.sweep_deform.armature is not None:
        return obj.sweep_deform.armature
    for md in modifier.armature_modifiers(obj):
        if md.object is not None:
            return md.object
    if obj.parent is not None and obj.parent.type == 'ARMATURE':
        return obj.parent
    return None


# ---- stage 1: read (main thread) ----------------------------------------------------------


def linked_reason(obj):
    """Why the object's binding cannot be changed in this file (its object or mesh is linked
    from a library: the binding lives in the object and was made for the mesh; a linked
    armature is fine), or None."""
    for what, data in ((f"'{obj.name}'", obj), (f"The mesh '{obj.data.name}'", obj.data)):
        if data is not None and data.library is not None:
            return f"{what} is linked from '{data.library.filepath}' and cannot be changed in this file"
    return None


def skeleton_arrays(arm):
    """Bone names, parents, rest matrices, heads, tails of an armature (bone order)."""
    bones = arm.data.bones
    B = len(bones)
    names = [b.name for b in bones]
    parents = arrays.parent_indices(names, [b.parent.name if b.parent else "" for b in bones])
    rest = np.empty(B * 16, np.float32)
    bones.foreach_get('matrix_local', rest)  # column-major, as the core wants
    heads = np.empty(B * 3, np.float32)
    bones.foreach_get('head_local', heads)
    tails = np.empty(B * 3, np.float32)
    bones.foreach_get('tail_local', tails)
    return names, parents, rest, heads.reshape(B, 3), tails.reshape(B, 3)


def skin_weights(obj, arm, bone_names, slots=SKIN_SLOTS):
    """(bone ids, weights) (V, slots) from the vertex groups named like deforming bones."""
    index = {n: i for i, n in enumerate(bone_names)}
    group_to_bone = np.full(max(len(obj.vertex_groups), 1), -1, np.int32)
    for g in obj.vertex_groups:
        b = arm.data.bones.get(g.name)
        if b is not None and b.use_deform:
            group_to_bone[g.index] = index[g.name]
    mesh = obj.data
    counts = np.fromiter((len(v.groups) for v in mesh.vertices), np.int64, len(mesh.vertices))
    flat = [(g.group, g.weight) for v in mesh.vertices for g in v.groups]
    groups = np.fromiter((g for g, _ in flat), np.int64, len(flat))
    weights = np.fromiter((w for _, w in flat), np.float32, len(flat))
    ids, w = arrays.dense_weights_from_flat(counts, groups, weights, group_to_bone, slots)
    used = max(int((w > 0.0).sum(axis=1).max(initial=0)), 1)  # no empty slots for the core
    return np.ascontiguousarray(ids[:, :used]), np.ascontiguousarray(w[:, :used])


def check_bindable(obj, arm):
    """Raises BindError saying why `obj` cannot get a binding to `arm` now (not a mesh, in
    Edit Mode, linked, unusable transforms). A mesh shared with other objects is fine: the
    binding lives in the object, the offsets in the object's own carrier."""
    if obj.type != 'MESH':
        raise BindError(f"'{obj.name}' is not a mesh")
    if obj.mode == 'EDIT':
        raise BindError("Leave Edit Mode before binding")
    linked = linked_reason(obj)
    if linked:
        raise BindError(f"{linked}: bind it in that file (a linked character keeps the binding it was saved with)")
    problem = checks.transforms_problem(obj.matrix_world, obj.name, arm.matrix_world, arm.name)
    if problem:
        raise BindError(f"{problem}: fix it before binding")


def read_inputs(obj, arm):
    """Stage 1: the mesh (its rest shape, object data without modifiers) and the armature's
    rest skeleton, in the armature's space."""
    check_bindable(obj, arm)
    mesh = obj.data
    if len(mesh.vertices) < 3 or len(mesh.polygons) < 1:
        raise BindError(f"'{obj.name}' has no faces to bind")
    inp = BindInputs()
    inp.object_name, inp.armature_name = obj.name, arm.name
    m = arm.matrix_world.inverted() @ obj.matrix_world
    inp.mesh_to_armature = [list(row) for row in m]
    inp.positions = arrays.transform_points(inp.mesh_to_armature, mesh_data.vertex_positions(mesh))
    inp.triangles = mesh_data.triangles(mesh)
    inp.bone_names, inp.parents, inp.rest, inp.heads, inp.tails = skeleton_arrays(arm)
    inp.skin_bones, inp.skin_weights = skin_weights(obj, arm, inp.bone_names)
    return inp


# ---- stages 2 and 3: native (any thread; no bpy) --------------------------------------------


#: What the core's automatic chain finding says when a skeleton is not a humanoid.
_CHAINS_PREFIX = "automatic chains: "
_CHAINS_SUFFIX = "; give the chains explicitly"


def fit_native(inp):
    """The product's rig: the core's automatic fitting (sd_fit_rig), for humanoids only: any
    other skeleton (a quadruped, a snake or chain) is refused by a BindError naming what was
    not found, before anything in the file changes.
    Returns (rig, sweep_ids, sweep_weights, bone_ids, bone_weights, report)."""
    try:
        result = native.fit_rig(inp.positions, inp.triangles, inp.parents, inp.rest, inp.heads, inp.tails,
                                bone_names=inp.bone_names, skin_bones=inp.skin_bones,
                                skin_weights=inp.skin_weights, keys_per_link=2)
    except native.NativeError as e:
        text = str(e)
        if _CHAINS_PREFIX in text:  # the interface has no way to give chains: say what is supported
            why = text[text.index(_CHAINS_PREFIX) + len(_CHAINS_PREFIX):].replace(_CHAINS_SUFFIX, "")
            raise BindError(fit_report.humanoid_refusal(f"no humanoid found: {why}")) from None
        raise
    try:
        report = result.report()
        problem = fit_report.humanoid_problem(report, inp.heads, inp.tails, inp.bone_names)
        if problem:
            raise BindError(fit_report.humanoid_refusal(problem))
        rig = result.rig()
        sid, sw, bid, bw = result.weights()
        return rig, sid, sw, bid, bw, report
    finally:
        result.close()


#: The rig maker (see the module's docstring).
fitter = fit_native


def rig_as_stored(rig):
    """(blob, the rig read back from that blob): the binding must be made with the latter.

    The core (libsweepdeform 0.1.0) re-normalises the key quaternions when it reads a rig
    blob, which changes their last bits in about two rigs of three (and a second round trip
    may change them again), so a rig read back from its blob can have another fingerprint
    than the rig a binding was made with, and sd_deformer_create then refuses the pair.
    Binding the rig *read from the stored blob* makes every later read of that blob give the
    same rig, so save/reload is exact."""
    blob = rig.serialize()
    return blob, native.Rig.deserialize(blob)


def fit_and_bind(inp, stage=None):
    """Stages 2 and 3. `stage(name)` is called before each (for progress)."""
    if stage:
        stage("fit")
    fitted, sid, sw, bid, bw, report = fitter(inp)
    blob, rig = rig_as_stored(fitted)
    if stage:
        stage("bind")
    binding = native.Binding.bind(rig, inp.positions, sid, sw, bid, bw)
    return BindOutputs(rig, blob, binding, report)


# ---- stage 4: store (main thread) ----------------------------------------------------------


def store(obj, arm, inp, out):
    """Stage 4: saves the binding in the object, puts the modifier in the stack, switches
    off the Armature modifier it replaces (remembering how it was)."""
    if len(obj.data.vertices) != out.binding.vertex_count:
        raise BindError("The mesh changed while binding; bind again")
    s = obj.sweep_deform
    persistence.store(obj, out.rig_blob, out.binding.serialize(), inp.bone_names, inp.rest,
                      out.rig.sweep_count, out.report)
    anatomy.fill_joints(obj)  # the elbows and knees of the anatomical effects, from the report
    s.armature = arm
    s.bound_armature = arm.name
    s.bound_armature_object = arm
    s.bound_armature_data = arm.data.name if arm.data is not None else ""
    s.bind_id = uuid.uuid4().hex
    s.state = 'BOUND'
    s.message = ""
    # The Armature modifier this one replaces: the one remembered by an earlier binding, else
    # the first that uses this armature. It is only switched off, never changed otherwise: it
    # keeps its object, so the artist's set-up survives, and a file saved with the binding
    # deforms by it where the extension is missing (see prepare_for_save).
    replaced = obj.modifiers.get(s.armature_modifier) if s.armature_modifier else None
    if replaced is None or replaced.type != 'ARMATURE':
        replaced = next((md for md in modifier.armature_modifiers(obj) if md.object == arm), None)
        if replaced is not None:
            s.armature_modifier = replaced.name
            s.armature_modifier_viewport = replaced.show_viewport
            s.armature_modifier_render = replaced.show_render
            s.armature_modifier_object = replaced.object
        else:
            s.armature_modifier = ""
    if replaced is not None:
        replaced.show_viewport = False
        replaced.show_render = False
        if replaced.object is None:  # cleared by a binding made before version 0.2
            replaced.object = s.armature_modifier_object or arm
        sync_replaced_modifier(obj)
    md = modifier.find(obj)
    if md is None:
        md = modifier.ensure(obj, before=replaced)
    modifier.carriers(obj, md, out.binding.vertex_count)  # zero offsets until the first frame
    deformer_cache.forget(obj)
    obj.update_tag()
    return md


def bind_object(obj, arm):
    """All stages at once (scripts, tests, the operator's non-interactive path)."""
    inp = read_inputs(obj, arm)
    out = fit_and_bind(inp)
    return store(obj, arm, inp, out)


def replaced_armature_modifier(obj):
    """The Armature modifier the binding switched off, or None."""
    s = obj.sweep_deform
    if not s.armature_modifier:
        return None
    md = obj.modifiers.get(s.armature_modifier)
    return md if md is not None and md.type == 'ARMATURE' else None


def sync_replaced_modifier(obj):
    """The replaced Armature modifier's Vertex Groups and Bone Envelopes follow its toggles.

    A switched-off Armature modifier that keeps its object still declares, in the depsgraph, a
    dependency of the mesh on every bone it would read (one per vertex group; the whole pose
    with envelopes): every pose change then evaluates the mesh once before the handler writes
    the carrier, for nothing, and once after. With neither input ticked it declares none (its
    object's transform only). So while it is off for viewport and render its two inputs are
    unticked, the artist's values remembered in Object.sweep_deform; whenever it is on again
    (the artist comparing, a save for Blender without the extension, unbinding) they are given
    back. Its object and every other setting stay as the artist made them. Returns True if it
    changed the modifier. Nothing is done for linked objects (Blender would not keep it)."""
    md_arm = replaced_armature_modifier(obj)
    if md_arm is None or obj.library is not None:
        return False
    s = obj.sweep_deform
    off = s.state != 'UNBOUND' and not md_arm.show_viewport and not md_arm.show_render
    if off and not s.armature_modifier_inputs_kept:
        # (a modifier switched on and off again by the artist is seen here, at the next update)
        s.armature_modifier_vertex_groups = md_arm.use_vertex_groups
        s.armature_modifier_envelopes = md_arm.use_bone_envelopes
        s.armature_modifier_inputs_kept = True
        if md_arm.use_vertex_groups:
            md_arm.use_vertex_groups = False
        if md_arm.use_bone_envelopes:
            md_arm.use_bone_envelopes = False
        return True
    if not off and s.armature_modifier_inputs_kept:
        _give_inputs_back(md_arm, s)
        return True
    return False


def _give_inputs_back(md_arm, s):
    """The replaced modifier's Vertex Groups and Bone Envelopes as the artist had them."""
    if s.armature_modifier_inputs_kept:
        if md_arm.use_vertex_groups != s.armature_modifier_vertex_groups:
            md_arm.use_vertex_groups = s.armature_modifier_vertex_groups
        if md_arm.use_bone_envelopes != s.armature_modifier_envelopes:
            md_arm.use_bone_envelopes = s.armature_modifier_envelopes
    s.armature_modifier_inputs_kept = False


def _portable(obj):
    """(Sweep Deform modifier, replaced Armature modifier) of a bound mesh object whose
    modifiers this file can change (a local object, or a library override, whose mesh may stay
    linked: the modifiers are the object's), or None."""
    if obj.type != 'MESH' or obj.sweep_deform.state == 'UNBOUND' or obj.library is not None:
        return None
    md_arm = replaced_armature_modifier(obj)
    md_sweep = modifier.find(obj)
    if md_arm is None or md_sweep is None:
        return None
    return md_sweep, md_arm


def prepare_for_save(obj):
    """For a file saved while bound (save_pre): the replaced Armature modifier as the artist
    had it (on, its object set) and the Sweep Deform modifier off (its toggles remembered in
    the object), so Blender *without* the extension (a render-farm node, a colleague's
    machine) deforms the character by the Armature modifier and never twice. The offsets stay
    in the mesh, so with the extension the file opens exactly as saved. Returns True if the
    object was prepared; restore_after_save() undoes it (save_post, load_post)."""
    found = _portable(obj)
    if found is None:
        return False
    md_sweep, md_arm = found
    s = obj.sweep_deform
    if not s.saved_for_blender_without_extension:
        s.sweep_modifier_viewport = md_sweep.show_viewport
        s.sweep_modifier_render = md_sweep.show_render
    md_sweep.show_viewport = False
    md_sweep.show_render = False
    md_arm.show_viewport = s.armature_modifier_viewport
    md_arm.show_render = s.armature_modifier_render
    if md_arm.object is None:
        md_arm.object = s.armature_modifier_object or s.armature
    s.saved_for_blender_without_extension = True
    _give_inputs_back(md_arm, s)  # the file on disk has the artist's Armature modifier
    return True


def restore_after_save(obj):
    """The extension is running (after a save, on load): the Sweep Deform modifier's toggles
    back as they were, the replaced Armature modifier off again (its object kept; one cleared
    by a version before issue 15 gets it back). Returns True if anything changed."""
    found = _portable(obj)
    if found is None:
        return False
    md_sweep, md_arm = found
    s = obj.sweep_deform
    changed = md_arm.show_viewport or md_arm.show_render or md_arm.object is None
    if s.saved_for_blender_without_extension:
        md_sweep.show_viewport = s.sweep_modifier_viewport
        md_sweep.show_render = s.sweep_modifier_render
        s.saved_for_blender_without_extension = False
        changed = True
    md_arm.show_viewport = False
    md_arm.show_render = False
    if md_arm.object is None:
        md_arm.object = s.armature_modifier_object or s.armature
    return sync_replaced_modifier(obj) or changed


def unbind(obj, restore_armature_modifier=True):
    """Removes the binding and the offsets; restores the Armature modifier it replaced.
    The Sweep Deform modifier itself stays (unbound, it does nothing)."""
    s = obj.sweep_deform
    md = obj.modifiers.get(s.armature_modifier) if s.armature_modifier else None
    if md is not None and md.type == 'ARMATURE':
        if restore_armature_modifier:
            md.show_viewport = s.armature_modifier_viewport
            md.show_render = s.armature_modifier_render
            if md.object is None:
                md.object = s.armature_modifier_object or s.armature
        _give_inputs_back(md, s)  # (also when it stays off: Apply baked the deformation)
    s.armature_modifier_inputs_kept = False
    s.armature_modifier = ""
    s.armature_modifier_object = None
    s.bound_armature_object = None
    persistence.clear(obj)
    s.message = ""
    deformer_cache.forget(obj)
    if obj.type == 'MESH':
        modifier.remove_carrier(obj)
