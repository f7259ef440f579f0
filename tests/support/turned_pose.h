// Posed bone matrices for tests that bend one joint: the rest skeleton with a bone and every
// bone below it turned by one rigid map.
#pragma once

#include "rig/skeleton.h"

#include <glm/gtc/matrix_transform.hpp>

#include <vector>

namespace sd::testing {

/// #B*16 column-major posed matrices: rest, but `turn * rest` for `bone` and its descendants.
inline std::vector<float> turned_pose(const Skeleton& s, int bone, const dmat4& turn) {
    std::vector<float> pose;
    pose.reserve(16 * static_cast<size_t>(s.bone_count()));
    for (int b = 0; b < s.bone_count(); ++b) {
        bool below = false;
        for (int x = b; x >= 0 && !below; x = s.parents[x]) below = x == bone;
        const dmat4 m = below ? turn * s.rest[b] : s.rest[b];
        for (int c = 0; c < 4; ++c)
            for (int r = 0; r < 4; ++r) pose.push_back(static_cast<float>(m[c][r]));
    }
    return pose;
}

/// A turn by `angle` radians about `axis` through `point`.
inline dmat4 turn_about(const dvec3& point, const dvec3& axis, double angle) {
    return glm::translate(dmat4(1.0), point) * glm::rotate(dmat4(1.0), angle, axis) *
           glm::translate(dmat4(1.0), -point);
}

}  // namespace sd::testing
