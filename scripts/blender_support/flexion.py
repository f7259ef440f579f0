# SPDX-License-Identifier: GPL-3.0-or-later
"""Exact joint flexion on an armature (used by test_anatomy.py and scripts/render_crease.py), and
a bone turned about its own head (the made bodies, the trunk's pictures, test_deform.py)."""

import bpy
import numpy as np
from mathutils import Matrix, Vector


def turn_about_head(arm, name, rotation):
    """Turns the pose bone `name` (and so its children) by `rotation`, a 3x3 rotation in world
    space, about its head, on top of the armature's current pose; updates the view layer."""
    pb = arm.pose.bones[name]
    world = arm.matrix_world
    head = world @ pb.head
    turn = Matrix.Translation(head) @ rotation.to_4x4() @ Matrix.Translation(-head)
    pb.matrix = world.inverted() @ turn @ world @ pb.matrix
    bpy.context.view_layer.update()


def link_angle(arm, lower):
    """Angle in degrees between the posed directions of `lower`'s parent and `lower`
    (0 = a straight limb)."""
    pl = arm.pose.bones[lower]
    pu = pl.parent
    du, dl = (pu.tail - pu.head).normalized(), (pl.tail - pl.head).normalized()
    return float(np.degrees(np.arccos(np.clip(du.dot(dl), -1.0, 1.0))))


def flex(arm, lower, toward, degrees):
    """Poses `arm` at rest except the joint whose lower link is the bone `lower`: that link (with
    its children) turned about the joint head so that it points at `degrees` from its parent's
    direction, in the plane of the parent and `toward` (armature space: the body's front for an
    elbow, its back for a knee). The turn is the smallest rotation taking the rest direction
    there. Returns link_angle() of the posed bones (degrees)."""
    for pb in arm.pose.bones:
        pb.matrix_basis.identity()
    lb = arm.data.bones[lower]
    ub = lb.parent
    u = (ub.tail_local - ub.head_local).normalized()
    t = Vector(toward)
    f = (t - t.dot(u) * u).normalized()
    a = np.radians(degrees)
    target = float(np.cos(a)) * u + float(np.sin(a)) * f
    turn = (lb.tail_local - lb.head_local).normalized().rotation_difference(target).to_matrix().to_4x4()
    joint = lb.head_local
    arm.pose.bones[lower].matrix = Matrix.Translation(joint) @ turn @ Matrix.Translation(-joint) @ lb.matrix_local
    bpy.context.view_layer.update()
    return link_angle(arm, lower)
