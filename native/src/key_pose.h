// Where the key ellipses are in a pose (Sect. 4.1): a joint key keeps its center at the
// joint and turns by a fraction of the joint's rotation (half-way by default, so its plane
// bisects the joint); an intermediate key follows its link rigidly.
#pragma once

#include "rig.h"

#include <vector>

namespace sd {

/// Splits a rotation r into swing * twist, twist about the unit `axis`.
void swing_twist(const dquat& r, const dvec3& axis, dquat* swing, dquat* twist);

/// The key ellipses' centers and orientations of `sweep` in `pose`.
void pose_keys(const Sweep& sweep, const SkeletonPose& pose, std::vector<dvec3>& centers,
               std::vector<dquat>& rotations);

}  // namespace sd
