#include "rig/key_correction.h"

#include <algorithm>
#include <array>
#include <cmath>

namespace sd {

double angle_between(const dvec3& u, const dvec3& v) {
    return std::atan2(glm::length(glm::cross(u, v)), glm::dot(u, v));
}

namespace {

constexpr int kValues = 8;  // dc.xyz, dr.xyz, ln sa, ln sb
using Sample = std::array<double, kValues>;

Sample sample_of(const KeyCorrection& c) {
    return {c.delta_center.x,   c.delta_center.y,   c.delta_center.z,    c.delta_rotation.x,
            c.delta_rotation.y, c.delta_rotation.z, std::log(c.scale_a), std::log(c.scale_b)};
}

KeyCorrectionValue value_of(const Sample& y) {
    KeyCorrectionValue v;
    v.delta_center = dvec3(y[0], y[1], y[2]);
    v.delta_rotation = dvec3(y[3], y[4], y[5]);
    v.scale_a = y[6] == 0.0 ? 1.0 : std::exp(y[6]);
    v.scale_b = y[7] == 0.0 ? 1.0 : std::exp(y[7]);
    return v;
}

/// Fritsch–Carlson slope at an interior sample (weighted harmonic mean of the secants, 0 at
/// a local extremum), which keeps the cubic monotone between monotone samples.
double interior_slope(double h0, double h1, double d0, double d1) {
    if (d0 * d1 <= 0.0) return 0.0;
    const double w1 = 2.0 * h1 + h0, w2 = h1 + 2.0 * h0;
    return (w1 + w2) / (w1 / d0 + w2 / d1);
}

}  // namespace

KeyCorrectionValue correction_at(const std::vector<KeyCorrection>& corrections, double rest_angle, double angle) {
    // Samples, sorted by angle, close ones averaged.
    std::vector<double> x;
    std::vector<Sample> y;
    std::vector<int> merged;
    for (const KeyCorrection& c : corrections) {
        if (c.muted) continue;
        const Sample s = sample_of(c);
        if (!x.empty() && std::abs(c.angle - x.back()) <= kCorrectionAngleTolerance) {
            const int n = ++merged.back();
            for (int i = 0; i < kValues; ++i) y.back()[i] += (s[i] - y.back()[i]) / n;
            continue;
        }
        x.push_back(c.angle);
        y.push_back(s);
        merged.push_back(1);
    }
    if (x.empty()) return {};
    // The rest pose keeps no correction unless one was made there.
    const bool at_rest = std::any_of(x.begin(), x.end(),
                                     [&](double xi) { return std::abs(xi - rest_angle) <= kCorrectionAngleTolerance; });
    if (!at_rest) {
        const auto it = std::lower_bound(x.begin(), x.end(), rest_angle);
        const auto i = it - x.begin();
        x.insert(it, rest_angle);
        y.insert(y.begin() + i, Sample{});
    }
    const int n = static_cast<int>(x.size());
    // Exactly a sample's value near it (the rest pose read back from float matrices).
    for (int i = 0; i < n; ++i)
        if (std::abs(angle - x[i]) <= 1e-5) return value_of(y[i]);
    if (angle <= x.front()) return value_of(y.front());
    if (angle >= x.back()) return value_of(y.back());
    const int i = static_cast<int>(std::upper_bound(x.begin(), x.end(), angle) - x.begin()) - 1;
    const double h = x[i + 1] - x[i], t = (angle - x[i]) / h;
    const double t2 = t * t, t3 = t2 * t;
    const double h00 = 2 * t3 - 3 * t2 + 1, h10 = t3 - 2 * t2 + t, h01 = -2 * t3 + 3 * t2, h11 = t3 - t2;
    Sample out{};
    for (int c = 0; c < kValues; ++c) {
        const auto slope = [&](int j) {
            if (j == 0 || j == n - 1) return 0.0;  // flat ends: C1 into the constant extension
            const double h0 = x[j] - x[j - 1], h1 = x[j + 1] - x[j];
            return interior_slope(h0, h1, (y[j][c] - y[j - 1][c]) / h0, (y[j + 1][c] - y[j][c]) / h1);
        };
        out[c] = h00 * y[i][c] + h10 * h * slope(i) + h01 * y[i + 1][c] + h11 * h * slope(i + 1);
    }
    return value_of(out);
}

dquat rotation_from_vector(const dvec3& v) {
    const double angle = glm::length(v);
    if (!(angle > 0.0)) return dquat(1, 0, 0, 0);
    return glm::angleAxis(angle, v / angle);
}

void apply_correction(const KeyCorrectionValue& c, dvec3& center, dquat& rotation, double& a, double& b) {
    if (c.is_identity()) return;
    center += glm::mat3_cast(rotation) * c.delta_center;
    if (c.delta_rotation != dvec3(0.0)) rotation = glm::normalize(rotation * rotation_from_vector(c.delta_rotation));
    a *= c.scale_a;
    b *= c.scale_b;
}

}  // namespace sd
