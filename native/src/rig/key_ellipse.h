// A key ellipse (Sect. 3.2): one cross-section of a limb that the sweep interpolates, and
// how it follows the skeleton (Sect. 4.1), with the artist's pose-space corrections
// (Sect. 4.2).
#pragma once

#include "math/math_types.h"

#include <vector>

namespace sd {

/// One edit of a key ellipse (Sect. 4.2), made while the key's joint stood at `angle`. It is
/// applied to the key placed by Sect. 4.1, in that key's own frame (columns: major axis,
/// minor axis, normal): center + R dc, orientation R exp(dr), half-axes a sa, b sb.
/// A key's corrections are samples of one function of the joint angle (key_pose.h).
struct KeyCorrection {
    double angle = 0.0;                   ///< joint angle in radians, [0, pi]
    dvec3 delta_center{0.0};              ///< along the key's axes, |dc| <= 10 max(a, b)
    dvec3 delta_rotation{0.0};            ///< rotation vector in the key's frame, |dr| <= pi/2
    double scale_a = 1.0, scale_b = 1.0;  ///< half-axis factors, in [0.1, 10]
    bool muted = false;                   ///< kept, but ignored by the interpolation
};

/// The correction a key gets at one joint angle (the interpolation of its corrections).
struct KeyCorrectionValue {
    dvec3 delta_center{0.0};
    dvec3 delta_rotation{0.0};
    double scale_a = 1.0, scale_b = 1.0;

    bool is_identity() const {
        return delta_center == dvec3(0.0) && delta_rotation == dvec3(0.0) && scale_a == 1.0 && scale_b == 1.0;
    }
};

/// The twist spread of a rig that does not say (the ABI's keys, blobs before version 3).
constexpr double kDefaultTwistSpread = 2.0;

struct KeyEllipse {
    dvec3 center{0.0};              ///< rest-pose center, armature space
    dquat orientation{1, 0, 0, 0};  ///< columns of its matrix: major axis, minor axis, normal
    double a = 1.0, b = 1.0;        ///< half-axes along the first and second column, > 0
    int bone = -1;                  ///< link it rides on, or the lower link of its joint
    int joint_parent = -1;          ///< the upper link of its joint; -1 for an intermediate key
    double swing_fraction = 0.5;    ///< joint keys: share of the joint's swing the key takes
    double twist_fraction = 0.5;    ///< joint keys: share of the twist about twist_axis()
    /// Joint keys: the rest direction the joint's twist is taken about, a unit vector, or zero
    /// for the key's normal. The neck's joint takes the neck's own line (joint to joint): the
    /// neck turns about itself, and about the joint's bisecting normal (6-18 degrees off it)
    /// a pure turn of the neck read as part swing, which the chest's last key followed.
    dvec3 twist_direction{0.0};
    /// End keys that twist (wrist, ankle, head): how their twist spreads back along the last
    /// link, whose keys take place^twist_spread of it (key_motion.cpp), in [1, 2]. The
    /// fitting lowers it from 2 on a mesh with few rings there (fit/twist_spread.h).
    double twist_spread = kDefaultTwistSpread;
    /// Pose-space corrections (Sect. 4.2), sorted by angle, at most one per angle.
    std::vector<KeyCorrection> corrections;

    bool is_joint_key() const { return joint_parent >= 0; }
    dvec3 normal() const { return glm::mat3_cast(orientation)[2]; }
    dvec3 twist_axis() const { return twist_direction == dvec3(0.0) ? normal() : twist_direction; }
};

}  // namespace sd
