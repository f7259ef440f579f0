// Distances between point sets, shared by the native tests: points are flat float arrays
// (x, y, z per point), results in the points' units, computed in double.
#pragma once

#include <glm/glm.hpp>

#include <algorithm>
#include <vector>

namespace sd::testing {

/// Length of the diagonal of the points' axis-aligned bounding box.
inline double diagonal(const std::vector<float>& p) {
    glm::dvec3 lo(1e30), hi(-1e30);
    for (size_t i = 0; i < p.size(); i += 3) {
        const glm::dvec3 v(p[i], p[i + 1], p[i + 2]);
        lo = glm::min(lo, v);
        hi = glm::max(hi, v);
    }
    return glm::length(hi - lo);
}

/// Largest distance between corresponding points of `a` and `b` (same size).
inline double max_distance(const std::vector<float>& a, const std::vector<float>& b) {
    double d = 0.0;
    for (size_t i = 0; i < a.size(); i += 3)
        d = std::max(d, glm::length(glm::dvec3(a[i] - b[i], a[i + 1] - b[i + 1], a[i + 2] - b[i + 2])));
    return d;
}

}  // namespace sd::testing
