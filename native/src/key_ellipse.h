// A key ellipse (Sect. 3.2): one cross-section of a limb that the sweep interpolates, and
// how it follows the skeleton (Sect. 4.1).
#pragma once

#include "math_types.h"

namespace sd {

struct KeyEllipse {
    dvec3 center{0.0};           ///< rest-pose center, armature space
    dquat orientation{1, 0, 0, 0};  ///< columns of its matrix: major axis, minor axis, normal
    double a = 1.0, b = 1.0;     ///< half-axes along the first and second column, > 0
    int bone = -1;               ///< link it rides on, or the lower link of its joint
    int joint_parent = -1;       ///< the upper link of its joint; -1 for an intermediate key
    double swing_fraction = 0.5; ///< joint keys: share of the joint's swing the key takes
    double twist_fraction = 0.5; ///< joint keys: share of the twist about its normal

    bool is_joint_key() const { return joint_parent >= 0; }
    dvec3 normal() const { return glm::mat3_cast(orientation)[2]; }
};

}  // namespace sd
