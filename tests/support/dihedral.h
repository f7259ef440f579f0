// The largest change of a skin edge's bend (the angle between its two triangles' normals)
// from rest to a pose, over part of a character: how sharply a deformation creases the skin.
#pragma once

#include "math/math_types.h"

#include <sweepdeform_io/character.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <utility>
#include <vector>

namespace sd::testing {

/// Dihedral angle change of every interior edge whose four vertices are all in `mask`.
inline double max_dihedral_change(const io::Character& c, const std::vector<float>& pos,
                                  const std::vector<char>& mask) {
    std::map<std::pair<int, int>, std::vector<int>> edge_tris;
    const int T = static_cast<int>(c.triangles.size() / 3);
    for (int t = 0; t < T; ++t)
        for (int i = 0; i < 3; ++i) {
            int a = c.triangles[3 * t + i], b = c.triangles[3 * t + (i + 1) % 3];
            if (a > b) std::swap(a, b);
            edge_tris[{a, b}].push_back(t);
        }
    const auto P = [](const std::vector<float>& p, int v) { return dvec3(p[3 * v], p[3 * v + 1], p[3 * v + 2]); };
    const auto normal = [&](const std::vector<float>& p, int t) {
        const dvec3 n = glm::cross(P(p, c.triangles[3 * t + 1]) - P(p, c.triangles[3 * t]),
                                   P(p, c.triangles[3 * t + 2]) - P(p, c.triangles[3 * t]));
        const double l = glm::length(n);
        return l > 0.0 ? n / l : n;
    };
    const auto angle = [](const dvec3& u, const dvec3& v) {
        return std::atan2(glm::length(glm::cross(u, v)), glm::dot(u, v));
    };
    double worst = 0.0;
    for (const auto& [e, tris] : edge_tris) {
        if (tris.size() != 2) continue;
        bool in = true;
        for (int t : tris)
            for (int i = 0; i < 3; ++i) in = in && mask[c.triangles[3 * t + i]];
        if (!in) continue;
        const double rest = angle(normal(c.positions, tris[0]), normal(c.positions, tris[1]));
        const double posed = angle(normal(pos, tris[0]), normal(pos, tris[1]));
        worst = std::max(worst, std::abs(posed - rest));
    }
    return worst;
}

}  // namespace sd::testing
