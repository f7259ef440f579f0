#include "rig/bent_joint_trajectory.h"

#include "math/smoothstep.h"

#include <algorithm>
#include <cmath>

namespace sd {

namespace {
constexpr double kPi = 3.14159265358979323846;
constexpr double kCut = 0.8;  // of sin^2(since / 2): 0.4 of the tangent at a right angle
// Fitted on the procedural characters' elbows and knees at 90 degrees: 0.5 met their knees'
// r_max alone (1.09 against Preserve Volume's 1.10), 0.75-0.9 the elbows' too (1.10-1.11).
constexpr double kFadeFrom = 0.5 * kPi, kFadeTo = 2.0 * kPi / 3.0;  // the joint's bend
constexpr double kThickFrom = 0.42, kThickTo = 0.50;                // the joint's fold
}  // namespace

double bent_joint_tangent_cut(double bend, double since, double fold) {
    const double s = std::sin(0.5 * since);
    const double open = 1.0 - smoothstep01((bend - kFadeFrom) / (kFadeTo - kFadeFrom));
    const double thin = 1.0 - smoothstep01((fold - kThickFrom) / (kThickTo - kThickFrom));
    return kCut * s * s * open * thin;
}

void tighten_bent_joints(const Sweep& s, SweepGeometry& posed) {
    if (s.bends_smoothly) return;
    const std::vector<dquat>& q = posed.key_rotations();
    const std::vector<dquat>& r = s.rest_geometry.key_rotations();
    const dvec3 z(0, 0, 1);
    for (int k = 1; k + 1 < s.key_count(); ++k) {
        if (!s.keys[k].is_joint_key()) continue;
        // The next key's normal seen from the previous key's frame: a twist about either
        // normal turns neither, so a twisted limb keeps its tangents.
        const dvec3 now = glm::conjugate(q[k - 1]) * (q[k + 1] * z);
        const dvec3 rest = glm::conjugate(r[k - 1]) * (r[k + 1] * z);
        const double since = std::acos(std::clamp(glm::dot(now, rest), -1.0, 1.0));
        if (!(since > 0.0)) continue;  // the rest pose: the paper's cubic, bit for bit
        const double bend = std::acos(std::clamp(now.z, -1.0, 1.0));
        const double chord = glm::length(s.keys[k + 1].center - s.keys[k - 1].center);
        const double fold = chord > 0.0 ? std::max(s.keys[k].a, s.keys[k].b) * bend / chord : 1.0;
        const double cut = bent_joint_tangent_cut(bend, since, fold);
        if (cut > 0.0) posed.scale_key_tangent(k, 1.0 - cut);
    }
}

SweepGeometry posed_geometry(const Sweep& s, const std::vector<dvec3>& centers, const std::vector<dquat>& rotations) {
    SweepGeometry g(centers, rotations);
    tighten_bent_joints(s, g);
    return g;
}

}  // namespace sd
