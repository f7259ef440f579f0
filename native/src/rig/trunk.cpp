#include "rig/trunk.h"

#include <cmath>

namespace sd {

std::vector<char> sweeps_leaving_trunk_sideways(const Rig& rig) {
    std::vector<char> sideways(rig.sweeps.size(), 0);
    dvec3 axis(0.0);
    for (const Sweep& s : rig.sweeps)
        if (!s.keys.front().is_joint_key() && s.key_count() >= 2) {
            axis = s.keys.back().center - s.keys.front().center;
            break;
        }
    if (!(glm::length(axis) > 0.0)) return sideways;
    axis = glm::normalize(axis);
    for (size_t si = 0; si < rig.sweeps.size(); ++si) {
        const KeyEllipse& k = rig.sweeps[si].keys.front();
        sideways[si] = k.is_joint_key() && std::abs(glm::dot(k.normal(), axis)) < std::cos(glm::radians(45.0));
    }
    return sideways;
}

}  // namespace sd
