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

void set_shoulder_motions(Rig& rig) {
    // The paper's joint key turns by half the joint's swing. At a shoulder the skin on top
    // of the joint lies before the arm's first plane and follows that key, so an arm lowered
    // from a T-pose turned it by half the arm's swing and the arm's sections after the key
    // by the rest: the top of the shoulder stayed flat up to the joint and then turned down
    // at a corner (MakeHuman re-rested in a T-pose, shoulder_abd_20: 14 intersecting pairs,
    // Preserve Volume 7, its deltoid a round dome). Lowered, the arm's first key takes all
    // of the swing and that skin wraps round the joint with the arm. Raised, the top of the
    // shoulder is the inside of the bend: with the whole swing it passed through itself
    // (shoulder_abd_160: 3-38 pairs on five bodies), and with half of it the arm's sections
    // made the other half of their turn between the shoulder key and the next, 8.6 cm apart
    // on MakeHuman: the inside of that span was squeezed along the sweep to 0.40 of its rest
    // thickness and the skin on top bunched into a lip where the arm meets the shoulder
    // (sharpest new crease there 68.8 degrees,
    // Shoulder.TheTopOfAShoulderRaised160DegreesCreasesLessThanWithHalfTheSwing). Raised, the
    // turn is spread over the web and two spans instead: the shoulder key takes 0.6 of the
    // swing, the next key 0.88 (its centre stays on the bone; only its plane lags), the rest
    // are rigid with the arm: thickness 0.70, 54.2 degrees, the lip flattened into a small
    // corner. A larger share at the shoulder key alone moved the crease into the web (0.7: 4
    // pairs on the 4.7K character); a larger lag narrowed the arm's section (0.85: the 75K
    // character's to 0.89 of rest; 0.7: MakeHuman's to 0.77).
    constexpr double kLoweringShare = 1.0, kRaisingShare = 0.6, kNextKeyRaisingShare = 0.88;
    const std::vector<char> sideways = sweeps_leaving_trunk_sideways(rig);
    const dvec3 down = -trunk_axis(rig);
    for (size_t si = 0; si < rig.sweeps.size(); ++si) {
        Sweep& s = rig.sweeps[si];
        KeyMotion& shoulder = s.motions.front();
        shoulder.lowering = sideways[si] ? down : dvec3(0.0);
        shoulder.lowering_share = sideways[si] ? kLoweringShare : 0.0;
        shoulder.raising_share = sideways[si] ? kRaisingShare : 0.0;
        // The key after the shoulder, where it rides the shoulder key's own bone (the upper
        // arm's first intermediate key): rigid with the bone, or lagging as the arm rises.
        if (s.key_count() < 3 || s.keys[1].is_joint_key() || s.keys[1].bone != s.keys[0].bone ||
            !s.keys[0].is_joint_key())
            continue;
        KeyMotion& next = s.motions[1];
        const bool rigid =
            next.blend.empty() && next.from_bone == next.to_bone && next.swing_share == 0.0 && next.twist_share == 0.0;
        const bool lagging = next.lowering != dvec3(0.0);
        if (!rigid && !lagging) continue;  // a key with a motion of its own (a twisting last link)
        next.to_bone = s.keys[1].bone;
        next.from_bone = sideways[si] ? s.keys[0].joint_parent : next.to_bone;
        next.swing_share = sideways[si] ? 1.0 : 0.0;
        next.twist_share = sideways[si] ? 1.0 : 0.0;
        next.axis = sideways[si] ? s.keys[0].normal() : dvec3(0, 0, 1);
        next.lowering = shoulder.lowering;
        next.lowering_share = sideways[si] ? 1.0 : 0.0;
        next.raising_share = sideways[si] ? kNextKeyRaisingShare : 0.0;
    }
}

}  // namespace sd
