# SPDX-License-Identifier: GPL-3.0-or-later
"""One frame of one character: evaluated pose → core → offsets in the mesh's attribute.

A small cache keeps, per bound object, the native deformer (re-created lazily from the
object's blobs after load or undo), its buffers (no allocation per frame) and the key of
the state it last wrote: the pose matrices, the mesh→armature linear map, the volume
settings and the key-ellipse corrections. :func:`evaluate` returns at once when that key has
not changed, which is what keeps the handlers from feeding the depsgraph their own writes
back (see handlers.py).

Key-ellipse corrections (Sect. 4.2) are ordinary properties of the object
(``sweep_deform.corrections``), so they can be keyframed, driven and undone; they are what
the add-on uses. Every evaluation reads them (one ``foreach_get`` per field; in a render
from the render depsgraph's copy, so animated values are the frame's) and, when they
changed, hands them to the native rig and deformer (``sd_deformer_set_rig_corrections``: microseconds, where creating
the deformer again costs milliseconds). The rig blob's own copy of the corrections is
written when the file is saved (persistence.py) and ignored when it is read.
"""

import json

import numpy as np

from . import modifier, persistence, rig_io, transforms
from .core import native

_cache = {}


class Entry:
    """The runtime state of one bound object."""

    def __init__(self, obj):
        self.bind_id = obj.sweep_deform.bind_id
        self.armature_name = obj.sweep_deform.armature.name if obj.sweep_deform.armature else ""
        self.error = ""
        self.load_error = ""  # why the stored binding could not be used (error may say more)
        self.deformer = None
        self.key = None
        self.settings = None
        self.labels = []
        self.frames = 0
        self.rest_checked = False
        self.unusable = False
        self.last_pose = None
        self.rig = None
        self.corrections_key = None
        self.correction_error = ""
        self.overlay = None
        self.overlay_key = None
        self.binding = None
        self.anatomy = None
        self.anatomy_key = None
        self.anatomy_error = ""
        self.anatomy_stats = None
        self.triangles = None
        try:
            rig, binding, names, rest_pose = persistence.load(obj)
            self.binding = binding  # kept for the anatomical effects (sd_anatomy_create)
            self.bone_names = names
            # The properties rule: the blob's corrections (written at save) are dropped, so the
            # rest shape below is the uncorrected one the binding was made against.
            rig.set_corrections([], [], [], [])
            self.rig = rig
            self.deformer = native.Deformer(rig, binding)
            self.labels = rig_io.sweep_labels([rig.keys(s)["bones"] for s in range(rig.sweep_count)], names,
                                              obj.get(persistence.REPORT_KEY, ""))
            self.rest_pose = rest_pose
            if rest_pose.size != 16 * self.deformer.bone_count:
                raise ValueError("the stored rest pose does not match the rig")
            # The core's own rest shape: offsets are measured from it, so the rest pose gives
            # exactly zero offsets.
            self.deformer.set_volume_preservation(False, 0.0)
            self.rest = self.deformer.deform(rest_pose, np.empty((self.deformer.vertex_count, 3), np.float32))
            self.pose = np.empty(16 * self.deformer.bone_count, np.float32)
            self.pose_buffer = None
            self.order = None
            self.order_names = None
            self.offsets = np.empty((self.deformer.vertex_count, 3), np.float32)
            self.scratch = np.empty((self.deformer.vertex_count, 3), np.float32)
            self._linear = None
            self._inverse = None
        except native.NativeLibraryError as e:
            # Not the file's fault: the panel says what is wrong with the installation.
            self.error = str(e)
            self.deformer = None
        except (native.NativeError, KeyError, ValueError) as e:
            # The stored binding cannot be used (damaged blob, bones missing, ...).
            self.error = self.load_error = str(e)
            self.deformer = None
            self.unusable = True

    def to_mesh_space(self, linear):
        """(3,3) float32 matrix taking armature-space row vectors to mesh space, or None
        for the identity (the usual case: no scale between mesh and armature)."""
        if self._linear is None or linear != self._linear:
            self._linear = linear.copy()
            m = np.array(linear, dtype=np.float64)
            self._inverse = None if np.array_equal(m, np.eye(3)) else np.linalg.inv(m).T.astype(np.float32)
        return self._inverse

    def close(self):
        """Frees the anatomy now (the deformer goes with the entry's last reference)."""
        if self.anatomy is not None:
            self.anatomy.close()
        self.anatomy = None
        self.anatomy_key = None

    def volumes(self):
        """(rest, before, after) per sweep of the last frame, or None before the first."""
        if self.deformer is None or self.frames == 0:
            return None
        return self.deformer.volumes()


def _key(obj):
    return (obj.name, obj.sweep_deform.bind_id)


# ---- anatomical effects (Sect. 4.3, 4.4) ----------------------------------------------------

#: Joint kinds of the properties → sd_joint_kind.
_JOINT_KINDS = {'ELBOW': native.JOINT_ELBOW, 'KNEE': native.JOINT_KNEE}


def report_joints(report):
    """The elbows and knees of a fitting report: [(label, lower bone name, kind, flexion
    direction)] from its arm and leg chains that got a sweep (their last bone is the joint's
    lower link); the flexion direction is the body's forward for an elbow, its back for a
    knee (armature space, as the report's body axes)."""
    try:
        r = json.loads(report) if report else {}
        forward = [float(x) for x in r.get("body", {}).get("forward", (0.0, -1.0, 0.0))]
        chains = r.get("chains", [])
    except (ValueError, AttributeError, TypeError):
        return []
    joints = []
    for ch in chains:
        try:
            kind = {"arm": 'ELBOW', "leg": 'KNEE'}.get(ch.get("kind"))
            names = ch.get("bone_names", [])
            if kind is None or ch.get("sweep", -1) < 0 or len(names) < 2:
                continue
            side = ch.get("side", 0)
            suffix = {1: " L", -1: " R"}.get(side, "") if isinstance(side, int) else ""
            label = ("Elbow" if kind == 'ELBOW' else "Knee") + (suffix or f" ({ch.get('name', names[-1])})")
            direction = forward if kind == 'ELBOW' else [-x for x in forward]
            joints.append((label, names[-1], kind, direction))
        except (AttributeError, TypeError):
            continue
    return joints


def fill_joints(obj):
    """(Re)fills ``sweep_deform.joints`` from the object's fitting report, keeping the
    switches of joints already there (by bone)."""
    s = obj.sweep_deform
    keep = {}
    for j in s.joints:
        keep[j.bone] = (j.use_folding, j.use_protrusion, j.use_bulge, j.protrusion_strength, j.bulge_strength)
    found = report_joints(obj.get(persistence.REPORT_KEY, ""))
    s.joints.clear()
    for label, bone, kind, direction in found:
        j = s.joints.add()
        j.name, j.bone, j.kind, j.flexion_direction = label, bone, kind, direction
        if bone in keep:
            (j.use_folding, j.use_protrusion, j.use_bulge, j.protrusion_strength,
             j.bulge_strength) = keep[bone]


def joint_effects(j):
    return ((native.EFFECT_FOLDING if j.use_folding else 0) | (native.EFFECT_PROTRUSION if j.use_protrusion else 0)
            | (native.EFFECT_BULGE if j.use_bulge else 0))


def anatomy_settings(settings):
    """The anatomical effects a SweepDeformSettings asks for: None when off, else per joint
    (bone, kind, flexion direction, effect mask, protrusion strength, bulge strength)."""
    if not settings.use_anatomy:
        return None
    return tuple((j.bone, j.kind, tuple(round(float(x), 7) for x in j.flexion_direction), joint_effects(j),
                  float(j.protrusion_strength), float(j.bulge_strength)) for j in settings.joints)


def mesh_triangles(mesh):
    """The mesh's loop triangles (T,3) int32, vertex indices in the mesh's (= the binding's) order."""
    mesh.calc_loop_triangles()
    tris = np.empty(len(mesh.loop_triangles) * 3, np.int32)
    mesh.loop_triangles.foreach_get('vertices', tris)
    return tris.reshape(-1, 3)


#: sd_anatomy_set_volume_feedback mode the add-on uses: two passes per frame, so a frame
#: depends on its pose only (a render, a scrub and playback give the same mesh).
VOLUME_FEEDBACK_MODE = 2


def make_anatomy(rig, binding, bone_names, triangles, joints):
    """A native Anatomy with the joints of `joints` (as :func:`anatomy_settings` gives them)
    switched as they say. Returns (anatomy, [error per joint that could not be added])."""
    anatomy = native.Anatomy(rig, binding, triangles)
    anatomy.set_volume_feedback(VOLUME_FEEDBACK_MODE, True)
    problems = []
    index = {n: i for i, n in enumerate(bone_names)}
    for bone, kind, direction, effects, protrusion, bulge in joints:
        if bone not in index:
            problems.append(f"{bone}: not in the rig")
            continue
        try:
            j = anatomy.add_joint(index[bone], _JOINT_KINDS[kind], direction)
            anatomy.set_joint_effects(j, effects)
            anatomy.set_joint_parameter(j, native.PARAM_PROTRUSION_STRENGTH, protrusion)
            anatomy.set_joint_parameter(j, native.PARAM_BULGE_STRENGTH, bulge)
        except native.NativeError as err:
            problems.append(f"{bone}: {str(err).split(': ', 2)[-1]}")
    return anatomy, problems


def sync_anatomy(e, obj, settings):
    """Creates, re-creates or drops the entry's Anatomy to match `settings`. Returns its key."""
    key = anatomy_settings(settings)
    if key == e.anatomy_key:
        return key
    if e.anatomy is not None:
        e.anatomy.close()
        e.anatomy = None
    e.anatomy_stats = None
    e.anatomy_error = ""
    # The effects hand their volume (I_C) to the deformer as offsets: without them the target
    # is V0 again, exactly as a deformer that never had them.
    e.deformer.set_volume_offsets(np.zeros(e.deformer.sweep_count, np.float32))
    e.anatomy_key = key
    if key is None:
        return key
    try:
        if e.triangles is None:
            e.triangles = mesh_triangles(obj.data)
        e.anatomy, problems = make_anatomy(e.rig, e.binding, e.bone_names, e.triangles, key)
        e.anatomy_error = "; ".join(problems)
        if not key:
            e.anatomy_error = "No elbows or knees in the fitting report: bind again with the automatic fitting"
    except (native.NativeError, ValueError) as err:
        e.anatomy = None
        e.anatomy_error = str(err)
    return key


# ---- key-ellipse corrections (Sect. 4.2) ---------------------------------------------------


def correction_arrays(settings):
    """(sweeps, keys, angles, values (N,8), muted) of a SweepDeformSettings' corrections, as
    the ABI takes them, read with one foreach_get per field."""
    coll = settings.corrections
    n = len(coll)
    sweeps, keys = np.empty(n, np.int32), np.empty(n, np.int32)
    angles, scale_a, scale_b = np.empty(n, np.float32), np.empty(n, np.float32), np.empty(n, np.float32)
    offset, rotation = np.empty(3 * n, np.float32), np.empty(3 * n, np.float32)
    muted = np.empty(n, bool)
    if n:
        coll.foreach_get("sweep", sweeps)
        coll.foreach_get("key", keys)
        coll.foreach_get("angle", angles)
        coll.foreach_get("offset", offset)
        coll.foreach_get("rotation", rotation)
        coll.foreach_get("scale_a", scale_a)
        coll.foreach_get("scale_b", scale_b)
        coll.foreach_get("mute", muted)
    values = np.concatenate([offset.reshape(n, 3), rotation.reshape(n, 3), scale_a[:, None], scale_b[:, None]],
                            axis=1).astype(np.float32)
    return sweeps, keys, angles, values, muted.astype(np.int32)


def sync_corrections(e, settings):
    """Hands the corrections of `settings` to the entry's rig and deformer if they changed.
    Returns the corrections' key (part of the evaluation key). Invalid corrections are
    refused by the core: the previous ones stay, and the panel shows why."""
    arrays = correction_arrays(settings)
    key = b"".join(a.tobytes() for a in arrays)
    if key != e.corrections_key:
        e.corrections_key = key
        try:
            e.deformer.set_rig_corrections(*arrays)
            e.rig.set_corrections(*arrays)
            e.correction_error = ""
        except native.NativeError as err:
            e.correction_error = str(err).split(": ", 2)[-1]
    return key


def corrections_changed(obj):
    """A correction property changed (the next evaluation hands them on); redraw the overlay."""
    redraw_views()


def redraw_views():
    try:
        import bpy
        wm = bpy.context.window_manager
    except (ImportError, AttributeError):
        return
    if wm is None:
        return
    for window in wm.windows:
        for area in window.screen.areas:
            if area.type in ('VIEW_3D', 'PROPERTIES'):
                area.tag_redraw()


def current_pose(obj, depsgraph=None):
    """The pose of the last evaluation (rig order, #B*16 float32), else read now."""
    e = entry(obj)
    if e.deformer is None:
        return None
    if e.last_pose is not None:
        return e.last_pose
    import bpy
    arm = obj.sweep_deform.armature
    if arm is None:
        return None
    dg = depsgraph or bpy.context.evaluated_depsgraph_get()
    try:
        return _armature_pose(e, arm.evaluated_get(dg)).copy()
    except KeyError:
        return None


def key_state(obj, sweep, key):
    """Everything an edit of one key ellipse needs, in the armature's space, for the current
    pose: its joint angle and rest angle, the key as Sect. 4.1 places it (center, rotation,
    half-axes) and as shown with its correction, and the correction's current values."""
    e = entry(obj)
    if e.deformer is None:
        raise RuntimeError(e.error or "the character is not bound")
    sync_corrections(e, obj.sweep_deform)
    pose = current_pose(obj)
    placed = e.rig.pose_keys(sweep, pose, corrected=False)
    shown = e.rig.pose_keys(sweep, pose, corrected=True)
    _, _, rest_angle = e.rig.key_joint(sweep, key)
    angle = float(placed["angles"][key])
    from . import key_edit
    return dict(
        angle=angle, rest_angle=float(rest_angle),
        center=placed["centers"][key].astype(np.float64),
        rotation=key_edit.quat_to_matrix(placed["orientations"][key]),
        half_axes=placed["half_axes"][key].astype(np.float64),
        shown_center=shown["centers"][key].astype(np.float64),
        shown_rotation=key_edit.quat_to_matrix(shown["orientations"][key]),
        shown_half_axes=shown["half_axes"][key].astype(np.float64),
        values=e.rig.key_correction_at(sweep, key, angle).astype(np.float64),
        rest_half_axes=e.rig.keys(sweep)["half_axes"][key].astype(np.float64))


#: Samples per span of the overlay's sweep wireframe.
OVERLAY_RINGS_PER_SPAN = 4


def overlay_data(obj):
    """The key ellipses and sweeps of the current pose, in the armature's space (cached per
    pose and corrections): per sweep a dict with the corrected keys (centers, rotations
    (K,3,3), half_axes), the keys as Sect. 4.1 places them, and sampled sweep points."""
    e = entry(obj)
    if e.deformer is None or e.rig is None:
        return None
    sync_corrections(e, obj.sweep_deform)
    pose = current_pose(obj)
    key = (None if pose is None else pose.tobytes(), e.corrections_key)
    if key == e.overlay_key and e.overlay is not None:
        return e.overlay
    from . import key_edit
    sweeps = []
    for s in range(e.rig.sweep_count):
        shown = e.rig.pose_keys(s, pose, corrected=True)
        placed = e.rig.pose_keys(s, pose, corrected=False)
        K = len(shown["centers"])
        spans = K - 1
        u = np.linspace(0.0, 1.0, spans * OVERLAY_RINGS_PER_SPAN + 1, dtype=np.float32)
        wire = e.rig.evaluate_posed_sweep(s, u, pose)
        sweeps.append(dict(
            centers=shown["centers"].astype(np.float64),
            rotations=np.array([key_edit.quat_to_matrix(q) for q in shown["orientations"]]),
            half_axes=shown["half_axes"].astype(np.float64),
            placed_centers=placed["centers"].astype(np.float64),
            placed_rotations=np.array([key_edit.quat_to_matrix(q) for q in placed["orientations"]]),
            placed_half_axes=placed["half_axes"].astype(np.float64),
            angles=shown["angles"].astype(np.float64),
            wire_centers=wire["centers"], wire_rotations=wire["rotations"], wire_half_axes=wire["half_axes"],
            key_rings=list(range(0, len(u), OVERLAY_RINGS_PER_SPAN))))
    e.overlay, e.overlay_key = sweeps, key
    return sweeps


def entry(obj):
    """The object's cache entry, created on first use."""
    k = _key(obj)
    e = _cache.get(k)
    if e is None:
        e = _cache[k] = Entry(obj)
    return e


def peek(obj):
    """The entry if one exists (for the panel; never creates one)."""
    return _cache.get(_key(obj))


def forget(obj):
    for k in [k for k in _cache if k[0] == obj.name]:
        _cache.pop(k).close()
    bound_changed()


def forget_armature(arm):
    """The armature left Edit Mode: its bound characters check its rest pose again."""
    for e in _cache.values():
        if e.armature_name == arm.name:
            e.rest_checked = False


def clear():
    for e in _cache.values():
        e.close()
    _cache.clear()
    _bound.clear()
    bound_changed()


def settings_changed(obj):
    """A volume setting changed: the next evaluation recomputes (the key includes them)."""
    e = peek(obj)
    if e is not None:
        e.key = None


# ---- state changes ---------------------------------------------------------------------


def _set_rebind(obj, message):
    from . import bind
    if bind.linked_reason(obj):
        # Library data is never written (Blender would not save it): the panel says why.
        _refuse(entry(obj), obj, message)
        return
    s = obj.sweep_deform
    if s.state != 'REBIND':
        s.state = 'REBIND'
    if s.message != message:
        s.message = message
    forget(obj)
    modifier.clear_offsets(obj.data)


def _modifier_gone(obj):
    """The Sweep Deform modifier left the stack: applied or removed. Either way the binding
    ends. If the rest positions are untouched it was removed, and the Armature modifier it
    replaced gets its deformation back; if they changed it was applied (the deformation is in
    the mesh now), and re-enabling the Armature modifier would deform twice."""
    from . import bind
    linked = bind.linked_reason(obj)
    if linked:  # nothing can be restored here, only said
        _refuse(entry(obj), obj, f"The Sweep Deform modifier is gone, but the binding stays: {linked}")
        return
    removed = persistence.rest_positions_match(obj) if persistence.counts_match(obj) else False
    bind.unbind(obj, restore_armature_modifier=removed)


def check_topology(obj):
    """Full check (connectivity hash); marks the object 'REBIND' on a change. True if fine."""
    s = obj.sweep_deform
    if s.state != 'BOUND':
        return False
    if not persistence.topology_matches(obj):
        _set_rebind(obj, "The mesh's topology changed after binding: bind again")
        return False
    return True


# ---- one frame -------------------------------------------------------------------------


#: What the user is told after a refused frame, and what happens.
KEPT = "the mesh keeps its last good deformation until this is fixed"


def _refuse(e, obj, message):
    """A frame that cannot be deformed: nothing is written, the panel shows `message` (the
    entry's error) and the console gets it once (command-line renders have no panel)."""
    if message != e.error:
        print(f"Sweep Deform: '{obj.name}': {message}")
    e.error = message


def linked_mesh_message(obj):
    """Why a linked mesh is not deformed (None if the mesh is local). Blender ignores an
    add-on's writes into library data, so the offsets cannot go into it."""
    lib = obj.data.library
    if lib is None:
        return None
    return (f"The mesh '{obj.data.name}' is linked from '{lib.filepath}': Sweep Deform cannot write its "
            "deformation into linked data, so it shows the shape saved in that file. To animate it here, make "
            "it local (Object > Relations > Make Local > Selected Objects and Data), or a library override "
            "of it first")


def _armature_pose(e, arm_eval):
    """The evaluated pose in the rig's bone order (#B*16 float32), or raises KeyError."""
    bones = arm_eval.pose.bones
    n = len(bones)
    if e.pose_buffer is None or e.pose_buffer.size != 16 * n:
        e.pose_buffer = np.empty(16 * n, np.float32)
        e.order_names = None
    names = [b.name for b in bones]
    if names != e.order_names:
        e.order = rig_io.pose_order(e.bone_names, names)
        e.order_names = names
    bones.foreach_get('matrix', e.pose_buffer)
    return rig_io.gather_pose(e.pose_buffer, e.order, e.pose)


def _rest_pose_matches(e, arm):
    bones = arm.data.bones
    rest = np.empty(16 * len(bones), np.float32)
    bones.foreach_get('matrix_local', rest)
    try:
        order = rig_io.pose_order(e.bone_names, [b.name for b in bones])
    except KeyError:
        return False
    rest = rig_io.gather_pose(rest, order)
    return rest.size == e.rest_pose.size and np.allclose(rest, e.rest_pose, rtol=0.0, atol=1e-5)


def evaluate(obj, depsgraph, render=False):
    """Updates the offsets of one bound mesh object for the pose in `depsgraph`.
    Returns True if it wrote new offsets."""
    s = obj.sweep_deform
    if s.state != 'BOUND' or obj.mode == 'EDIT':
        return False
    md = modifier.find(obj)
    if md is None:
        _modifier_gone(obj)
        return False
    if not modifier.active(md, render):
        return False
    arm = s.armature
    if arm is None or arm.mode == 'EDIT':
        return False
    linked = linked_mesh_message(obj)
    if linked:
        _refuse(entry(obj), obj, linked)
        return False
    if obj.data.users > 1:
        _set_rebind(obj, f"The mesh '{obj.data.name}' is used by several objects: make it single user "
                         "and bind again")
        return False
    if not persistence.counts_match(obj):
        _set_rebind(obj, "The mesh's topology changed after binding: bind again")
        return False
    e = entry(obj)
    if e.deformer is None:
        if e.unusable:
            _set_rebind(obj, f"The stored binding cannot be used ({e.load_error}): bind again")
        return False
    if not e.rest_checked:
        e.rest_checked = True
        if not _rest_pose_matches(e, arm):
            _set_rebind(obj, f"The rest pose of '{arm.name}' changed after binding: bind again")
            return False
    arm_eval = arm.evaluated_get(depsgraph)
    obj_eval = obj.evaluated_get(depsgraph)
    try:
        pose = _armature_pose(e, arm_eval)
    except KeyError as err:
        _set_rebind(obj, f"{err.args[0]}: bind again")
        return False
    problem = transforms.transforms_problem(obj_eval.matrix_world, obj.name, arm_eval.matrix_world, arm.name)
    if problem:
        _refuse(e, obj, f"{problem}: {KEPT}")
        e.key = None
        return False
    # Offsets are vectors: only the linear part of mesh → armature space maps them back.
    try:
        linear = (arm_eval.matrix_world.inverted() @ obj_eval.matrix_world).to_3x3()
        to_mesh = e.to_mesh_space(linear)
    except (ValueError, np.linalg.LinAlgError):  # flat in float32 though not quite in float64
        _refuse(e, obj, f"The object '{obj.name}' or its armature has a zero scale: {KEPT}")
        e.key = None
        return False
    settings = (bool(s.use_volume_preservation), float(s.volume_strength))
    # Corrections: in the viewport from the object itself (Blender copies animated and driven
    # values back to it for the active depsgraph, and a removed item is seen at once); in a
    # render from the render depsgraph's copy, which holds that frame's animated values.
    corrections = sync_corrections(e, obj_eval.sweep_deform if render else s)
    anatomy = sync_anatomy(e, obj, obj_eval.sweep_deform if render else s)
    key = (pose.tobytes(), tuple(linear.col[0]) + tuple(linear.col[1]) + tuple(linear.col[2]), settings,
           corrections, anatomy)
    if key == e.key and rig_io.OFFSET_ATTRIBUTE in obj.data.attributes:
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
        _refuse(e, obj, f"Unusable pose: {transforms.name_bones(str(err), e.bone_names)}: {KEPT}")
        e.key = key
        return False
    offsets = rig_io.offsets_into(deformed, e.rest, to_mesh, e.offsets, e.scratch)
    if not np.isfinite(offsets).all():  # e.g. a nearly flat object whose inverse overflows
        _refuse(e, obj, f"The deformation of '{obj.name}' is not finite here: {KEPT}")
        e.key = key
        return False
    modifier.write_offsets(obj.data, offsets)
    e.last_pose = pose.copy()  # the overlay and key edits follow the pose the mesh shows
    e.key = key
    e.error = ""
    e.frames += 1
    return True


_bound = {}      # scene name -> (object count, generation, [object names])
_generation = 0  # bumped by every bind, unbind, load and undo


def bound_changed():
    """The set of bound objects may have changed (bind, unbind, load, undo)."""
    global _generation
    _generation += 1


def bound_objects(scene):
    """Mesh objects of the scene with a binding (any state but UNBOUND). Scanning every
    object on every depsgraph update would cost a large scene dearly: the list is kept until
    the scene's object count or the generation changes."""
    objects = scene.objects
    cached = _bound.get(scene.name)
    if cached is None or cached[0] != len(objects) or cached[1] != _generation:
        names = [o.name for o in objects if o.type == 'MESH' and o.sweep_deform.state != 'UNBOUND']
        cached = _bound[scene.name] = (len(objects), _generation, names)
    found = []
    for name in cached[2]:
        o = objects.get(name)
        if o is None or o.type != 'MESH' or o.sweep_deform.state == 'UNBOUND':
            _bound.pop(scene.name, None)  # renamed or unbound: scan again next time
            continue
        found.append(o)
    return found
