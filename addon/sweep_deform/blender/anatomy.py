# SPDX-License-Identifier: GPL-3.0-or-later
"""The anatomical effects (Sect. 4.3, 4.4) of a bound character: its elbows and knees (from
the fitting report, into ``sweep_deform.joints``) and the native Anatomy that the cache entry
keeps in step with the properties."""

import numpy as np

from ..core import fit_report, native
from . import mesh_data, persistence

#: Joint kinds of the properties → sd_joint_kind.
_JOINT_KINDS = {'ELBOW': native.JOINT_ELBOW, 'KNEE': native.JOINT_KNEE}

#: sd_anatomy_set_volume_feedback mode the add-on uses: I_C put back within the frame (one
#: pass of the effects, the sweeps again), so a frame depends on its pose only (a render, a
#: scrub and playback give the same mesh).
VOLUME_FEEDBACK_MODE = 2


def fill_joints(obj):
    """(Re)fills ``sweep_deform.joints`` from the object's fitting report, keeping the
    switches of joints already there (by bone)."""
    s = obj.sweep_deform
    keep = {}
    for j in s.joints:
        keep[j.bone] = (j.use_folding, j.use_protrusion, j.use_bulge, j.protrusion_strength, j.bulge_strength)
    found = fit_report.report_joints(obj.get(persistence.REPORT_KEY, ""))
    s.joints.clear()
    for label, bone, kind, direction in found:
        j = s.joints.add()
        j.name, j.bone, j.kind, j.flexion_direction = label, bone, kind, direction
        if bone in keep:
            (j.use_folding, j.use_protrusion, j.use_bulge, j.protrusion_strength,
             j.bulge_strength) = keep[bone]


def joint_effects(j):
    """The sd_joint_effect mask of one SweepDeformJoint's switches."""
    return ((native.EFFECT_FOLDING if j.use_folding else 0) | (native.EFFECT_PROTRUSION if j.use_protrusion else 0)
            | (native.EFFECT_BULGE if j.use_bulge else 0))


def anatomy_settings(settings):
    """The anatomical effects a SweepDeformSettings asks for: None when off, else per joint
    (bone, kind, flexion direction, effect mask, protrusion strength, bulge strength)."""
    if not settings.use_anatomy:
        return None
    return tuple((j.bone, j.kind, tuple(round(float(x), 7) for x in j.flexion_direction), joint_effects(j),
                  float(j.protrusion_strength), float(j.bulge_strength)) for j in settings.joints)


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
    """Creates, re-creates or drops the cache entry's Anatomy to match `settings`. Returns its key."""
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
            e.triangles = mesh_data.triangles(obj.data)
        e.anatomy, problems = make_anatomy(e.rig, e.binding, e.bone_names, e.triangles, key)
        e.anatomy_error = "; ".join(problems)
        if not key:
            e.anatomy_error = "No elbows or knees in the fitting report: bind again with the automatic fitting"
    except (native.NativeError, ValueError) as err:
        e.anatomy = None
        e.anatomy_error = str(err)
    return key
