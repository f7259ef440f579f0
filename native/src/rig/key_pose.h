// Where the key ellipses are in a pose (Sect. 4.1): a joint key keeps its center at the
// joint and turns by a fraction of the joint's rotation (half-way by default, so its plane
// bisects the joint); an intermediate key follows its link rigidly.
//
// Then the artist's corrections (Sect. 4.2): "the orientation of the key ellipse is a
// function of the joint angle; a change at an extreme angle modifies this function smoothly
// using spline interpolation". Every key has a joint (KeyJoint, rig.h) whose angle — the
// angle between the directions of its two links, 0 for a straight limb — selects the
// correction: the key's corrections are samples over that angle, interpolated by a monotone
// cubic (key_correction.h), and the result moves, turns and scales the placed key in its own frame.
#pragma once

#include "rig/key_correction.h"
#include "rig/rig.h"

#include <vector>

namespace sd {

/// Splits a rotation r into swing * twist, twist about the unit `axis`.
void swing_twist(const dquat& r, const dvec3& axis, dquat* swing, dquat* twist);

/// The key ellipses' centers and orientations of `sweep` in `pose` (Sect. 4.1 only).
void pose_keys(const Sweep& sweep, const SkeletonPose& pose, std::vector<dvec3>& centers,
               std::vector<dquat>& rotations);

/// The angle (radians, [0, pi]) between the directions of the joint's two links in `pose`:
/// rot(M_parent) parent_axis against rot(M_child) child_axis. 0 when the joint has no parent.
double joint_angle(const KeyJoint& joint, const SkeletonPose& pose);

/// Sect. 4.2 after Sect. 4.1: corrects the posed keys of pose_keys() in place.
/// @param a, b  #K, in: the key half-axes to start from, out: scaled by the corrections
/// @param angles  optional #K output: each key's joint angle in `pose`
void correct_keys(const Sweep& sweep, const SkeletonPose& pose, std::vector<dvec3>& centers,
                  std::vector<dquat>& rotations, std::vector<double>& a, std::vector<double>& b,
                  std::vector<double>* angles = nullptr);

}  // namespace sd
