#include "rig/sweep.h"

#include <algorithm>
#include <cmath>

namespace sd {

SweepGeometry::SweepGeometry(const std::vector<dvec3>& centers, const std::vector<dquat>& rotations)
    : knots_(chord_length_knots(centers)), spans_(interpolate_cubic(centers, knots_)), q_(rotations) {
    for (size_t i = 1; i < q_.size(); ++i)
        if (glm::dot(q_[i - 1], q_[i]) < 0.0) q_[i] = -q_[i];
}

void SweepGeometry::scale_key_tangent(int key, double factor) {
    if (key <= 0 || key >= static_cast<int>(spans_.size())) return;
    CubicSpan& before = spans_[key - 1];  // ends at the key: + (u^3 - u^2) dm1
    const dvec3 dm1 = (factor - 1.0) * before.derivative(1.0);
    before.c[2] -= dm1;
    before.c[3] += dm1;
    CubicSpan& after = spans_[key];  // starts at the key: + (u^3 - 2u^2 + u) dm0
    const dvec3 dm0 = (factor - 1.0) * after.c[1];
    after.c[1] += dm0;
    after.c[2] -= 2.0 * dm0;
    after.c[3] += dm0;
}

dvec3 sweep_point(const SweepGeometry& g, const HalfAxisFunctions& h, int span, double u, double theta) {
    const dvec2 ab = h.at(span, u);
    return g.rotation(span, u) * dvec3(ab.x * std::cos(theta), ab.y * std::sin(theta), 0.0) + g.center(span, u);
}

void split_parameter(int span_count, double s, int* span, double* u) {
    s = std::clamp(s, 0.0, 1.0) * span_count;
    const int i = std::min(static_cast<int>(s), span_count - 1);
    *span = i;
    *u = s - i;
}

}  // namespace sd
