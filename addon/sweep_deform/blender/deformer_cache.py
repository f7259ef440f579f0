# SPDX-License-Identifier: GPL-3.0-or-later
"""The deformer cache: per bound object, what lives only in memory between frames.

An :class:`Entry` holds the native rig, binding and deformer (re-created lazily from the
object's blobs after load or undo), its buffers (no allocation per frame), the anatomical
effects, and the key of the state it last wrote: the pose matrices, the mesh→armature linear
map, the volume settings, the key-ellipse corrections and the anatomical effects. frame.py
returns at once when that key has not changed, which is what keeps the handlers from feeding
the depsgraph their own writes back (see handlers.py). Entries are keyed by object name and
bind id, so a new binding never meets an old entry.

An undo or redo step keeps the last generation's deformers by what their joint volume tables
were measured on, so that a new entry for the same binding and mesh takes the tables
instead of bending every limb joint again (0.28 s for the 53.5K MakeHuman: a hitch at every
undo step, per character).
"""

import hashlib
import json
import threading

import bpy
import numpy as np

from ..core import arrays, fit_report, native
from . import bound_objects, mesh_data, persistence, shape_keys

_cache = {}
_retired = {}  # (bind id, triangles' SHA-1) -> a deformer of the last generation


class Entry:
    """The in-memory state of one bound object."""

    def __init__(self, obj):
        self.bind_id = obj.sweep_deform.bind_id
        self.armature_name = obj.sweep_deform.armature.name if obj.sweep_deform.armature else ""
        self.error = ""
        self.load_error = ""  # why the stored binding could not be used (error may say more)
        self.deformer = None
        self.written = {}  # carrier name -> the key of the state written into it
        self.refused_key = None  # a state refused (unusable pose): not tried again
        self.lock = threading.RLock()  # one evaluation at a time (see frame.evaluate)
        self._packed = None
        self._mesh_rest = self._shape_key_buffers = self._moves_last = None
        self.moves_seen = 0  # changes of the shape keys' displacements (moving)
        self.moved_flat = None  # arrays.flat_rows of the vertices they move
        self._moves_mix = None  # the shape key buffers' mix count moving() saw last
        self.render_carrier_for = None  # (modifier, point count) the render carrier was made for
        # The mesh carrier (modifier.py): the mesh it copies, whether that changed since, the
        # deformed positions' buffer and the keys' displacements last added to them.
        self.mesh_pointer = self.mesh_copied = None  # the object's mesh; the one last copied
        self.mesh_stale = True  # a new entry (after load, undo, a new binding) copies afresh
        self._positions = None
        self.whole_moves = None
        self.matrices_seen = None  # (object, armature) world matrices last found usable
        self.settings = None
        self.labels = []
        self.frames = 0
        self.rest_checked = False
        self.armature_seen = None
        # The per-frame output check (core/output_check.py): made on first use; the warning of
        # the last frame that needed the fallback (empty after a good frame).
        self.output_check = None
        self.output_check_error = ""
        self.warning = ""
        self.fallback = None
        self.fallback_frames = 0
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
        self.joints_held = 0  # limb joints whose mesh volume is held (sd_deformer_hold_joint_volumes)
        self.joint_volume_error = ""  # why it is not, shown in the panel
        self.trunk_fill_error = ""  # why the trunk's volume is not given to its skin, shown in the panel
        self.tables_key = None  # what its joint volume tables were measured on (_retired)
        try:
            rig, binding, names, rest_pose = persistence.load(obj)
            self.binding = binding  # kept for the anatomical effects (sd_anatomy_create)
            self.bone_names = names
            # The properties rule: the blob's corrections (written at save) are dropped, so the
            # rest shape below is the uncorrected one the binding was made against.
            rig.set_corrections([], [], [], [])
            self.rig = rig
            self.deformer = native.Deformer(rig, binding)
            self.labels = fit_report.sweep_labels([rig.keys(s)["bones"] for s in range(rig.sweep_count)], names,
                                                  obj.get(persistence.REPORT_KEY, ""))
            self.rest_pose = rest_pose
            if rest_pose.size != 16 * self.deformer.bone_count:
                raise ValueError("the stored rest pose does not match the rig")
            # The core's own rest shape: offsets are measured from it, so the rest pose gives
            # exactly zero offsets.
            self.deformer.set_volume_preservation(False, 0.0)
            self.rest = self.deformer.deform(rest_pose, np.empty((self.deformer.vertex_count, 3), np.float32))
            # The mesh's volume at the limb joints, measured once on the bound mesh (the core bends
            # each joint alone): 25 frames' time per joint, at every load. A mesh whose vertex
            # count changed since binding is refused further on, with its own message.
            if len(obj.data.vertices) == self.deformer.vertex_count:
                self.triangles = mesh_data.triangles(obj.data)  # kept for the anatomical effects
                self.trunk_fill_error = _fill_trunk(obj, self.deformer, self.triangles)
                if self.trunk_fill_error:  # the binding still deforms, without it
                    print(f"Sweep Deform: '{obj.name}': {self.trunk_fill_error}")
                self.joints_held, self.joint_volume_error, self.tables_key = _hold_joint_volumes(
                    obj, self.deformer, self.triangles)
                if self.joint_volume_error:  # the binding still deforms, without it
                    print(f"Sweep Deform: '{obj.name}': {self.joint_volume_error}")
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

    def armature_pose(self, arm_eval):
        """The evaluated pose in the rig's bone order (#B*16 float32), or raises KeyError."""
        bones = arm_eval.pose.bones
        n = len(bones)
        if self.pose_buffer is None or self.pose_buffer.size != 16 * n:
            self.pose_buffer = np.empty(16 * n, np.float32)
            self.order_names = None
        names = bones.keys()  # in C: 6 µs for MakeHuman's 53 bones, 29 µs by name one by one
        if names != self.order_names:
            self.order = arrays.pose_order(self.bone_names, names)
            self.order_names = names
        bones.foreach_get('matrix', self.pose_buffer)
        return arrays.gather_pose(self.pose_buffer, self.order, self.pose)

    def rest_pose_matches(self, arm):
        """Whether the armature's rest pose is still the one the binding was made with."""
        return self.rest_pose_problem(arm) is None

    def rest_pose_problem(self, arm):
        """None if the armature's bones and rest pose are the ones the binding was made with,
        else what changed, precisely: the bones that are gone (deleted or renamed), or the
        bones whose rest matrix moved (the one that moved most first)."""
        bones = arm.data.bones
        names = [b.name for b in bones]
        present = set(names)
        missing = [n for n in self.bone_names if n not in present]
        if missing:
            more = f" and {len(missing) - 4} more" if len(missing) > 4 else ""
            shown = ", ".join(f"'{n}'" for n in missing[:4]) + more
            return (f"the bone{'s' if len(missing) > 1 else ''} {shown} of '{arm.name}' "
                    f"{'were' if len(missing) > 1 else 'was'} deleted or renamed after binding")
        rest = np.empty(16 * len(bones), np.float32)
        bones.foreach_get('matrix_local', rest)
        rest = arrays.gather_pose(rest, arrays.pose_order(self.bone_names, names))
        if rest.size != self.rest_pose.size:
            return f"the bones of '{arm.name}' changed after binding"
        change = np.abs(rest.reshape(-1, 16) - self.rest_pose.reshape(-1, 16)).max(axis=1)
        moved = [self.bone_names[i] for i in np.argsort(-change) if change[i] > 1e-5]
        if not moved:
            return None
        shown = ", ".join(f"'{n}'" for n in moved[:3]) + (f" and {len(moved) - 3} more" if len(moved) > 3 else "")
        return f"the rest pose of '{arm.name}' changed after binding (bone{'s' if len(moved) > 1 else ''} {shown})"

    def packed_buffer(self, obj):
        """(5V,3) float32, a carrier's blocks with the local linear maps (modifier.FRAME_BLOCKS):
        offsets, the three rows of J - I, the mesh's rest positions (filled once, here)."""
        if self._packed is None:
            V = self.deformer.vertex_count
            self._packed = np.empty((5 * V, 3), np.float32)
            self._packed[4 * V:] = self.mesh_rest(obj)
        return self._packed

    def positions_buffer(self):
        """(V,3) float32: the deformed positions written into the mesh carrier."""
        if self._positions is None:
            self._positions = np.empty((self.deformer.vertex_count, 3), np.float32)
        return self._positions

    def mesh_rest(self, obj):
        """(V,3) float32 the mesh's own vertex positions (mesh space), read once: what shape
        keys and earlier modifiers are measured from."""
        if self._mesh_rest is None:
            self._mesh_rest = mesh_data.vertex_positions(obj.data)
        return self._mesh_rest

    def shape_key_buffers(self):
        """The object's buffers for reading and mixing its shape keys (shape_keys.displacements)."""
        if self._shape_key_buffers is None:
            self._shape_key_buffers = shape_keys.ShapeKeyBuffers(self.deformer.vertex_count)
        return self._shape_key_buffers

    def moving(self, moved, rows, mix=None):
        """(moved, rows): the vertices the keys move and their displacements, or None when none
        moves; self.moves_seen counts the changes (a key's value or shape), so that the frame's
        key sees them. `mix`: the shape key buffers' mix count when they hold (moved, rows);
        the same as last time, they hold what they held then and are not compared again."""
        if moved.size == 0:
            return None
        last = self._moves_last
        if last is not None and mix is not None and mix == self._moves_mix:
            return moved, rows
        self._moves_mix = mix
        if last is None or not (np.array_equal(moved, last[0]) and np.array_equal(rows, last[1])):
            self._moves_last = (moved.copy(), rows.copy())
            self.moved_flat = arrays.flat_rows(moved)
            self.moves_seen += 1
        return moved, rows

    def moves_copy(self):
        """The last moving()'s (moved, rows) as copies of their own (replaced, never changed, when
        the keys' displacements change)."""
        return self._moves_last

    def forget_writes(self):
        """The next evaluation computes and writes again, whatever it finds."""
        self.written.clear()
        self.refused_key = None
        self.render_carrier_for = None

    def refuse(self, obj, message):
        """A frame that cannot be deformed: nothing is written, the panel shows `message` (the
        entry's error) and the console gets it once (command-line renders have no panel)."""
        if message != self.error:
            print(f"Sweep Deform: '{obj.name}': {message}")
        self.error = message

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


def _fill_trunk(obj, deformer, triangles):
    """The trunk's volume given back to its skin when it bends (the core's trunk_fill.h), on the
    object's own `triangles`; a mesh bound through another's map fills as that source does, so
    that the two stay together. Returns why not, or ""."""
    source_name = json.loads(obj.get(persistence.REPORT_KEY, "") or "{}").get("bound_through_map_of")
    try:
        if source_name:
            source = bpy.data.objects.get(source_name)
            src = entry(source) if source is not None and source.type == 'MESH' else None
            if src is None or src.deformer is None:
                return (f"the trunk's volume is not given to its skin: '{source_name}', whose map it was bound "
                        "through, is not a bound mesh in this file")
            deformer.fill_trunk_as(src.deformer)
        else:
            deformer.set_skin_triangles(triangles)
        return ""
    except (native.NativeError, ValueError) as e:
        return f"the trunk's volume is not given to its skin: {e}"


def _hold_joint_volumes(obj, deformer, triangles):
    """Holds the mesh's volume at the limb joints (sd_deformer_hold_joint_volumes), measured on
    the object's `triangles`; for a mesh bound through another's map, the source's tables, so that
    both follow the same sweeps (a point cloud has no volume of its own). A deformer of the
    cache's last generation (before an undo or redo step) for the same binding and triangles
    gives its tables instead of a new measurement, and so do the tables kept in the file at its
    last save (persistence.store_joint_volumes). Returns (joints held, why not or "", the key
    of the tables it measured, or None)."""
    source_name = json.loads(obj.get(persistence.REPORT_KEY, "") or "{}").get("bound_through_map_of")
    try:
        if source_name:  # (the source's entry keeps its own: a copy is never ahead of its source)
            source = bpy.data.objects.get(source_name)
            src = entry(source) if source is not None and source.type == 'MESH' else None
            if src is None or src.deformer is None:
                return 0, (f"the volume at the joints is not held: '{source_name}', whose map it was bound "
                           "through, is not a bound mesh in this file"), None
            return deformer.hold_joint_volumes_of(src.deformer), "", None
        key = (obj.sweep_deform.bind_id, hashlib.sha1(np.ascontiguousarray(triangles).tobytes()).hexdigest())
        kept = _retired.pop(key, None)
        if kept is not None:
            try:
                return deformer.hold_joint_volumes_of(kept), "", key
            except native.NativeError:  # (another rig after all: measured below)
                pass
        stored = persistence.stored_joint_volumes(obj, key)  # kept in the file at its last save
        if stored is not None:
            try:
                return deformer.load_joint_volumes(stored), "", key
            except native.NativeError as e:  # damaged: measured again, and kept anew at the next save
                print(f"Sweep Deform: '{obj.name}': the joints' volume tables kept in the file are not usable "
                      f"({e}): measured again")
        return deformer.hold_joint_volumes(triangles), "", key
    except (native.NativeError, ValueError) as e:
        return 0, f"the volume at the joints is not held: {e}", None


def keep_joint_volumes(obj):
    """At save: keeps the object's measured joint volume tables in the file (persistence), so
    that it opens without measuring them. An error is printed, never raised (a save must not
    fail for it)."""
    e = peek(obj)
    if e is None or e.deformer is None or e.tables_key is None or obj.library is not None:
        return
    try:
        persistence.store_joint_volumes(obj, e.deformer, e.tables_key)
    except (native.NativeError, native.NativeLibraryError, ValueError, RuntimeError, TypeError) as err:
        print(f"Sweep Deform: '{obj.name}': the joints' volume tables were not kept in the file "
              f"(measured again when it is opened): {err}")


def _key(obj):
    return (obj.name, obj.sweep_deform.bind_id)


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
    bound_objects.changed()


def forget_armature(arm):
    """The armature left Edit Mode: its bound characters check its rest pose again."""
    for e in _cache.values():
        if e.armature_name == arm.name:
            e.rest_checked = False


def clear(keep_tables=True):
    """Drops every entry (load, undo, redo); with `keep_tables` (undo, redo) the deformers whose
    joint volume tables they measured (or read) are kept until the next clear, for new entries of
    the same bindings to take the tables from (none held is a result too)."""
    global _retired
    _retired = {e.tables_key: e.deformer for e in _cache.values()
                if keep_tables and e.deformer is not None and e.tables_key is not None}
    for e in _cache.values():
        e.close()
    _cache.clear()
    bound_objects.clear()


def mesh_changed(mesh, keys_only=False):
    """The mesh was edited (attributes, UVs, materials, ...): the mesh carriers copying it are
    copied again at their next write, and its shape keys are read again. `keys_only`: only its
    shape keys were updated (values, or the keys' shapes)."""
    pointer = mesh.as_pointer()
    for e in _cache.values():
        if e.mesh_pointer == pointer:
            if not keys_only:
                e.mesh_stale = True
            if e._shape_key_buffers is not None:
                e._shape_key_buffers.forget()


def settings_changed(obj):
    """A volume setting changed: the next evaluation recomputes (the key includes them)."""
    e = peek(obj)
    if e is not None:
        e.forget_writes()
