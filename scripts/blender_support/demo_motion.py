# SPDX-License-Identifier: GPL-3.0-or-later
"""A demo motion for a rigged human that comes without one (the MakeHuman male in
blend_fixtures/ has no action): one key pose per joint the demo looks at, each eased in from
rest, held and eased out, with a timeline marker on it.

Rotations are given as anatomical movements, not as numbers on a rig's local axes: a bone
swings towards a direction in the rest pose (the character faces -Y, Z up, its left is +X), about
an axis found from the skeleton itself, so the same table poses any rig with these bones
whatever their rolls. Each local rotation is R_rest^-1 · R_world · R_rest, that is a rotation
about the given axis carried along by the bone's parents.
"""

import math

import bpy
from mathutils import Matrix, Quaternion, Vector

#: Bone roles and the names they have in the supported rigs (MakeHuman "game_engine" first,
#: then Sweep Deform's procedural characters in blend_fixtures/).
ROLES = {
    "pelvis": ["pelvis"],
    "spine_01": ["spine_01"], "spine_02": ["spine_02"], "spine_03": ["spine_03"],
    "clavicle_{s}": ["clavicle_{s}", "clavicle.{S}"],
    "upperarm_{s}": ["upperarm_{s}", "upper_arm.{S}"],
    "lowerarm_{s}": ["lowerarm_{s}", "forearm.{S}"],
    "hand_{s}": ["hand_{s}", "hand.{S}"],
    "neck": ["neck_01", "neck"], "head": ["head"],
    "foot_{s}": ["foot_{s}", "foot.{S}"],
    "thigh_{s}": ["thigh_{s}", "thigh.{S}"],
    "calf_{s}": ["calf_{s}", "shin.{S}"],
}

#: (marker, joint the close-up shows) in the order the motion plays them.
POSES = [
    ("arms_up", "shoulder"),
    ("elbow_bend", "elbow"),
    ("forearm_twist", "forearm"),
    ("knee_bend", "knee"),
    ("hip_flex", "hip"),
    ("spine_bend", "spine"),
]
RAMP, HOLD = 12, 4           # frames from rest to a pose, frames it is held
BLOCK = 2 * RAMP + HOLD + 4  # frames per pose, rest included


def bone(arm, role, side="l"):
    for pattern in ROLES[role]:
        name = pattern.format(s=side, S=side.upper())
        if name in arm.pose.bones:
            return arm.pose.bones[name]
    return None


def direction(pb):
    b = pb.bone
    return (b.tail_local - b.head_local).normalized()


def swing(pb, axis, angle_deg, toward):
    """Local quaternion turning `pb` by angle about the world axis `axis`, its sign chosen so
    that the tail moves towards `toward`."""
    axis = Vector(axis).normalized()
    if axis.cross(direction(pb)).dot(Vector(toward)) < 0:
        axis = -axis
    return local(pb, axis, angle_deg)


def local(pb, axis, angle_deg):
    rest = pb.bone.matrix_local.to_3x3()
    world = Matrix.Rotation(math.radians(angle_deg), 3, Vector(axis).normalized())
    return (rest.inverted() @ world @ rest).to_quaternion()


def angle_between(a, b):
    return math.degrees(a.angle(b))


def pose_table(arm):
    """{marker: {pose bone: quaternion}} for the poses both sides have bones for."""
    up, front = Vector((0, 0, 1)), Vector((0, -1, 0))
    poses = {name: {} for name, _ in POSES}
    for s, sign in (("l", 1.0), ("r", -1.0)):
        ua, la, hand = bone(arm, "upperarm_{s}", s), bone(arm, "lowerarm_{s}", s), bone(arm, "hand_{s}", s)
        th, calf = bone(arm, "thigh_{s}", s), bone(arm, "calf_{s}", s)
        if ua is not None:
            # Shoulder abduction to 150 degrees in the frontal plane (about the front axis).
            d = direction(ua)
            rest_abd = math.degrees(math.atan2(abs(d.x), -d.z))
            poses["arms_up"][ua] = swing(ua, front, 150.0 - rest_abd, up)
        if ua is not None and la is not None:
            # Elbow flexion to 140 degrees between the segments, in the rest bend plane.
            du, dl = direction(ua), direction(la)
            axis = du.cross(dl) if du.cross(dl).length > 0.1 else du.cross(front)
            bend = angle_between(du, dl) if du.cross(dl).length > 0.1 else 0.0
            q = swing(la, axis, 140.0 - bend, -du)
            poses["elbow_bend"][la] = q
        if la is not None and hand is not None:
            # Forearm twist: the hand turned 180 degrees about the forearm axis (supination).
            poses["forearm_twist"][hand] = local(hand, direction(la), sign * 180.0)
        if ua is not None:  # the arms out of the way: a hand would hide the hip crease
            poses["hip_flex"][ua] = swing(ua, front, 45.0, up)
        if s == "l" and th is not None and calf is not None:
            # The legs move on the left side only: the right one stands.
            poses["knee_bend"][calf] = swing(calf, Vector((1, 0, 0)), 130.0, -front)
            poses["hip_flex"][th] = swing(th, Vector((1, 0, 0)), 90.0, front)
            poses["hip_flex"][calf] = swing(calf, Vector((1, 0, 0)), 90.0, -front)
    spine = [bone(arm, r) for r in ("spine_01", "spine_02", "spine_03")]
    for pb in spine:
        if pb is not None:
            poses["spine_bend"][pb] = swing(pb, Vector((1, 0, 0)), 15.0, front)
    return {k: v for k, v in poses.items() if v}


def add_demo_motion(arm, scene, name="demo_motion"):
    """Keys the poses into a new action on `arm` and puts a marker on each; returns the action
    or None if the rig has none of the bones."""
    table = pose_table(arm)
    if not table:
        return None
    arm.animation_data_create()
    arm.animation_data.action = bpy.data.actions.new(name)
    for pb in arm.pose.bones:
        pb.rotation_mode = 'QUATERNION'
    scene.timeline_markers.clear()
    scene.timeline_markers.new("rest", frame=1)
    moved = {pb for q in table.values() for pb in q}

    def key(frame, rotations):
        for pb in moved:
            pb.rotation_quaternion = rotations.get(pb, Quaternion())
            pb.keyframe_insert("rotation_quaternion", frame=frame)

    key(1, {})
    frame = 1 + 4
    for marker, _ in POSES:
        if marker not in table:
            continue
        rot = table[marker]
        key(frame, {})
        if marker == "forearm_twist":  # progressive: through 90 degrees, not a flip
            key(frame + RAMP // 2, {pb: Quaternion().slerp(q, 0.5) for pb, q in rot.items()})
        key(frame + RAMP, rot)
        scene.timeline_markers.new(marker, frame=frame + RAMP)
        key(frame + RAMP + HOLD, rot)
        key(frame + 2 * RAMP + HOLD, {})
        frame += BLOCK
    scene.frame_start, scene.frame_end = 1, frame
    for pb in moved:
        pb.rotation_quaternion = Quaternion()
    return arm.animation_data.action
