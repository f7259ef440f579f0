# SPDX-License-Identifier: GPL-3.0-or-later
"""The key ellipses of a bound character in the pose it shows (Sect. 4.1, 4.2), for the
panel, the overlay and the gizmos: one key's editing state, every key and sampled sweep of
the pose (cached per pose and corrections), the key to select when editing starts, and one
edit of a key (:class:`Edit`: the correction property it changes), as gizmos and scripts make it."""

import bpy
import numpy as np

from ..core import key_edit
from . import corrections, deformer_cache

#: Samples per span of the overlay's sweep wireframe.
OVERLAY_RINGS_PER_SPAN = 4


def current_pose(obj, depsgraph=None):
    """The pose of the last evaluation (rig order, #B*16 float32), else read now."""
    e = deformer_cache.entry(obj)
    if e.deformer is None:
        return None
    if e.last_pose is not None:
        return e.last_pose
    arm = obj.sweep_deform.armature
    if arm is None:
        return None
    dg = depsgraph or bpy.context.evaluated_depsgraph_get()
    try:
        return e.armature_pose(arm.evaluated_get(dg)).copy()
    except KeyError:
        return None


def key_state(obj, sweep, key):
    """Everything an edit of one key ellipse needs, in the armature's space, for the current
    pose: its joint angle and rest angle, the key as Sect. 4.1 places it (center, rotation,
    half-axes) and as shown with its correction, and the correction's current values."""
    e = deformer_cache.entry(obj)
    if e.deformer is None:
        raise RuntimeError(e.error or "the character is not bound")
    corrections.sync_corrections(e, obj.sweep_deform)
    pose = current_pose(obj)
    placed = e.rig.pose_keys(sweep, pose, corrected=False)
    shown = e.rig.pose_keys(sweep, pose, corrected=True)
    _, _, rest_angle = e.rig.key_joint(sweep, key)
    angle = float(placed["angles"][key])
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


def overlay_data(obj):
    """The key ellipses and sweeps of the current pose, in the armature's space (cached per
    pose and corrections): per sweep a dict with the corrected keys (centers, rotations
    (K,3,3), half_axes), the keys as Sect. 4.1 places them, and sampled sweep points."""
    e = deformer_cache.entry(obj)
    if e.deformer is None or e.rig is None:
        return None
    corrections.sync_corrections(e, obj.sweep_deform)
    pose = current_pose(obj)
    key = (None if pose is None else pose.tobytes(), e.corrections_key)
    if key == e.overlay_key and e.overlay is not None:
        return e.overlay
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


def first_joint_key(obj):
    """(sweep, key) to select when editing starts: the first interior joint key (an elbow or a
    knee), else key 0 of sweep 0."""
    e = deformer_cache.entry(obj)
    if e.rig is None or e.rig.sweep_count == 0:
        return -1, -1
    for sweep in range(e.rig.sweep_count):
        parents = e.rig.keys(sweep)["joint_parents"]
        for k in range(1, len(parents) - 1):
            if parents[k] >= 0:
                return sweep, k
    return 0, 0


# ---- the edit, as gizmos and scripts make it -------------------------------------------------


def selected_key(obj, sweep=-1, key=-1):
    s = obj.sweep_deform
    sweep = s.active_sweep if sweep < 0 else sweep
    key = s.active_key if key < 0 else key
    return sweep, key


def key_corrections(settings, sweep, key):
    """[(index in the collection, item)] of one key's corrections."""
    return [(i, c) for i, c in enumerate(settings.corrections) if c.sweep == sweep and c.key == key]


def write_values(item, values):
    v = [float(x) for x in values]
    if tuple(item.offset) != tuple(v[0:3]):
        item.offset = v[0:3]
    if tuple(item.rotation) != tuple(v[3:6]):
        item.rotation = v[3:6]
    if item.scale_a != v[6]:
        item.scale_a = v[6]
    if item.scale_b != v[7]:
        item.scale_b = v[7]


def item_values(item):
    return key_edit.as_values(item.offset, item.rotation, item.scale_a, item.scale_b)


class Edit:
    """One edit of one key ellipse in the current pose: the correction it changes (found
    within the merge angle, else created at the current angle, or at the rest angle when
    near it, starting from the interpolated value so nothing jumps) and where it started."""

    def __init__(self, obj, sweep, key):
        s = obj.sweep_deform
        self.obj_name = obj.name
        self.sweep, self.key = sweep, key
        self.state = key_state(obj, sweep, key)
        mine = [(i, c) for i, c in key_corrections(s, sweep, key) if not c.mute]
        found = key_edit.find_correction([c.angle for _, c in mine], self.state["angle"], s.merge_angle)
        self.created = found is None
        if self.created:
            e = deformer_cache.entry(obj)
            angle = key_edit.edit_angle(self.state["angle"], self.state["rest_angle"], s.merge_angle)
            start = e.rig.key_correction_at(sweep, key, angle).astype(np.float64)
            item = s.corrections.add()
            item.sweep, item.key, item.angle = sweep, key, angle
            write_values(item, start)
            self.index = len(s.corrections) - 1
        else:
            self.index = mine[found][0]
        s.active_correction = self.index
        item = s.corrections[self.index]
        self.start = item_values(item)
        self.max_offset = key_edit.max_offset(self.state["rest_half_axes"])

    @property
    def obj(self):
        return bpy.data.objects[self.obj_name]

    def set(self, mode, amount):
        """The correction = the start with one edit of `amount` applied (see key_edit.apply)."""
        values = key_edit.apply(mode, self.start, amount, self.state["rotation"])
        values = key_edit.clamp_values(values, self.max_offset)
        write_values(self.obj.sweep_deform.corrections[self.index], values)
        return values

    def cancel(self):
        s = self.obj.sweep_deform
        if self.created:
            s.corrections.remove(self.index)
            s.active_correction = max(0, min(s.active_correction, len(s.corrections) - 1))
            self.obj.update_tag()
        else:
            write_values(s.corrections[self.index], self.start)


def apply_edit(obj, mode, amount, sweep=-1, key=-1):
    """Applies one edit to a key ellipse of `obj` in its current pose (what a gizmo drag
    ends with). Returns the correction's new values."""
    sweep, key = selected_key(obj, sweep, key)
    if sweep < 0 or key < 0:
        raise ValueError("no key ellipse is selected")
    return Edit(obj, sweep, key).set(mode, amount)
