#include "fit/twist_spread.h"

#include "rig/key_ellipse.h"

#include <algorithm>
#include <cmath>
#include <vector>

namespace sd::fit {

double rings_along(const FitMesh& mesh, const PartShares& shares, int chain, const dvec3& start, const dvec3& end) {
    const dvec3 d = end - start;
    const double length = glm::length(d);
    if (!(length > 0.0)) return 0.0;
    const dvec3 axis = d / length;
    const std::vector<dvec3>& p = mesh.positions();
    const auto beside = [&](int v) {
        if (shares.at(v, chain) < 0.5f) return false;
        const double x = glm::dot(p[v] - start, axis);
        return x >= 0.0 && x <= length;
    };
    std::vector<double> along;
    const std::vector<int32_t>& t = mesh.triangles();
    for (size_t i = 0; i < t.size(); i += 3)
        for (int e = 0; e < 3; ++e) {
            const int a = t[i + e], b = t[i + (e + 1) % 3];
            if (!beside(a) || !beside(b)) continue;
            const dvec3 edge = p[b] - p[a];
            const double x = std::abs(glm::dot(edge, axis));
            if (x > 0.0 && x >= 0.7 * glm::length(edge)) along.push_back(x);
        }
    if (along.size() < 8) return 0.0;
    std::nth_element(along.begin(), along.begin() + along.size() / 2, along.end());
    return length / along[along.size() / 2];
}

double twist_spread_for(double rings) {
    if (!(rings > 0.0)) return kDefaultTwistSpread;
    if (rings <= 1.0) return 1.0;
    const double p = std::log(1.0 - kLastRingGapShare) / std::log(1.0 - 1.0 / rings);
    return std::clamp(p, 1.0, 2.0);
}

}  // namespace sd::fit
