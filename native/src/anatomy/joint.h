// A joint with anatomical effects: the joint key ellipse of a sweep where an upper link
// meets a lower one (elbow, knee; or a generic joint such as a shoulder, hip or neck, where
// only the skin folding applies), its rest geometry, its per-joint switches and strengths,
// and what a pose does to it (flexion angle, the transforms bone proxies ride on).
#pragma once

#include "math/math_types.h"
#include "rig/rig.h"
#include "rig/skeleton.h"

namespace sd::anatomy {

enum class JointKind { Generic = 0, Elbow = 1, Knee = 2 };

/// Per-joint switches and strengths (the modifier panel's controls). Lengths are in the
/// rig's units; 0 means "automatic" where stated.
struct JointSettings {
    bool folding = true;               ///< collision-driven skin folding in the joint's region
    bool protrusion = true;            ///< bone proxies (olecranon, patella, user meshes)
    bool bulge = true;                 ///< muscle bulge (biceps, calf)
    double protrusion_strength = 1.0;  ///< 0..2, scales the push out of a proxy
    double protrusion_falloff = 0.0;   ///< radius of the smooth falloff around pushed skin; 0 = auto
    double bulge_strength = 0.15;      ///< 0..1, peak outward push at full activation, share of the local radius
    double bulge_falloff = 0.35;       ///< 0.05..0.5, width of the muscle region's smooth edge (share of its extent)
    double folding_falloff = 0.0;      ///< radius of the smooth falloff around pulled-back skin; 0 = auto
    double folding_margin = 0.0;       ///< gap kept between folded sheets; 0 = auto
    double region_radius = 0.0;        ///< collision region around the joint at rest; 0 = auto
};

struct Joint {
    JointKind kind = JointKind::Generic;
    int sweep = -1, key = -1;
    int upper_bone = -1, lower_bone = -1;
    dvec3 center{0.0};                     ///< rest, the joint key's center
    dvec3 upper_dir{0.0}, lower_dir{0.0};  ///< rest link directions, unit
    /// Rest, unit, orthogonal to upper_dir: where the lower link goes when the joint flexes
    /// (the front for an elbow, the back for a knee); zero when unknown (generic joints).
    dvec3 flexion_dir{0.0};
    double rest_bend = 0.0;  ///< signed rest angle of the lower link towards flexion_dir
    KeyEllipse key_ellipse;
    double upper_length = 0.0, lower_length = 0.0;
    double auto_region_radius = 0.0;  ///< the automatic collision region radius
    double region_radius = 0.0;       ///< resolved (settings, or automatic)
    JointSettings settings;

    bool has_flexion_direction() const { return glm::dot(flexion_dir, flexion_dir) > 0.0; }
    /// Radius of the joint key ellipse in direction d (projected onto its plane).
    double ellipse_radius(const dvec3& d) const;
};

/// Finds the joint key whose lower link is `lower_bone` (a joint key with that bone and a
/// joint parent) and fills the rest geometry. @throws InvalidInput when there is none.
/// @param flexion_direction  nullptr for none; else any vector not parallel to the upper link
Joint make_joint(const Rig& rig, int lower_bone, JointKind kind, const dvec3* flexion_direction);

/// What a pose does to a joint.
struct JointPose {
    dvec3 center{0.0};             ///< posed joint center
    double flexion = 0.0;          ///< radians beyond the rest bend, towards the flexion direction
    double bend = 0.0;             ///< unsigned angle between the posed link directions
    dmat4 upper{1.0}, lower{1.0};  ///< the links' deformation matrices
    dquat relative{1, 0, 0, 0};    ///< rotation of the lower link relative to the upper one
    dvec3 rest_center{0.0};
    /// M_upper * T(J) * R(slerp(1, relative, f)) * T(-J): f = 1 rides rigidly with the lower
    /// link (when the links meet at J), f = 0.5 with the bisector, f = 0 with the upper link.
    dmat4 fractional(double f) const;
};

JointPose pose_joint(const Joint& joint, const SkeletonPose& pose);

}  // namespace sd::anatomy
