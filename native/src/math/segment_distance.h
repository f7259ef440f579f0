// The distance from a point to a segment (a bone from head to tail): to the nearest point of
// the segment, its ends included. Skin near a bone and a bone hung from the bone nearest it
// both measure it.
#pragma once

#include "math/math_types.h"

#include <algorithm>

namespace sd {

inline double segment_distance(const dvec3& p, const dvec3& a, const dvec3& b) {
    const dvec3 e = b - a;
    const double len2 = glm::dot(e, e);
    const double t = len2 > 0.0 ? std::clamp(glm::dot(p - a, e) / len2, 0.0, 1.0) : 0.0;
    return glm::length(p - (a + t * e));
}

}  // namespace sd
