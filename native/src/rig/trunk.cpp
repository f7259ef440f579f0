#include "rig/trunk.h"

#include <cmath>

namespace sd {

dvec3 trunk_axis(const Rig& rig) {
    for (const Sweep& s : rig.sweeps)
        if (!s.keys.front().is_joint_key() && s.key_count() >= 2) {
            const dvec3 axis = s.keys.back().center - s.keys.front().center;
            return glm::length(axis) > 0.0 ? glm::normalize(axis) : dvec3(0.0);
        }
    return dvec3(0.0);
}

std::vector<char> sweeps_leaving_trunk_sideways(const Rig& rig) {
    std::vector<char> sideways(rig.sweeps.size(), 0);
    const dvec3 axis = trunk_axis(rig);
    if (axis == dvec3(0.0)) return sideways;
    for (size_t si = 0; si < rig.sweeps.size(); ++si) {
        const KeyEllipse& k = rig.sweeps[si].keys.front();
        sideways[si] = k.is_joint_key() && std::abs(glm::dot(k.normal(), axis)) < std::cos(glm::radians(45.0));
    }
    return sideways;
}

void set_shoulder_lowering(Rig& rig) {
    // The paper's joint key turns by half the joint's swing. At a shoulder the skin on top
    // of the joint lies before the arm's first plane and follows that key, so an arm lowered
    // from a T-pose turned it by half the arm's swing and the arm's sections after the key
    // by the rest: the top of the shoulder stayed flat up to the joint and then turned down
    // at a corner (MakeHuman re-rested in a T-pose, shoulder_abd_20: 14 intersecting pairs,
    // Preserve Volume 7, its deltoid a round dome). Lowered, the arm's first key takes all
    // of the swing and that skin wraps round the joint with the arm. Raised, it keeps half:
    // there the top of the shoulder is the inside of the bend, and with the whole swing it
    // passed through itself (shoulder_abd_160: 3-38 pairs on five bodies, 0 with half).
    constexpr double kLoweringShare = 1.0;
    const std::vector<char> sideways = sweeps_leaving_trunk_sideways(rig);
    const dvec3 down = -trunk_axis(rig);
    for (size_t si = 0; si < rig.sweeps.size(); ++si) {
        KeyMotion& m = rig.sweeps[si].motions.front();
        m.lowering = sideways[si] ? down : dvec3(0.0);
        m.lowering_share = sideways[si] ? kLoweringShare : 0.0;
    }
}

}  // namespace sd
