// Sect. 3.2: the trajectory interpolates the key centers with chord-length knots; a(t), b(t)
// interpolate the key half-axes.
#include "math/interpolating_curves.h"

#include <gtest/gtest.h>

namespace sd {
namespace {

TEST(CubicTrajectory, InterpolatesPointsAndIsC2) {
    const std::vector<dvec3> p = {{0, 0, 0}, {1, 0.5, 0}, {2, 0, 0.3}, {3.5, -1, 0}, {4, 0, 1}};
    const auto t = chord_length_knots(p);
    const auto spans = interpolate_cubic(p, t);
    ASSERT_EQ(spans.size(), 4u);
    for (size_t i = 0; i < spans.size(); ++i) {
        EXPECT_LT(glm::length(spans[i].value(0) - p[i]), 1e-12);
        EXPECT_LT(glm::length(spans[i].value(1) - p[i + 1]), 1e-12);
    }
    for (size_t i = 0; i + 1 < spans.size(); ++i) {  // C1 and C2 in t, not only in u
        const double h0 = t[i + 1] - t[i], h1 = t[i + 2] - t[i + 1];
        EXPECT_LT(glm::length(spans[i].derivative(1) / h0 - spans[i + 1].derivative(0) / h1), 1e-9);
        const dvec3 d2a = (2.0 * spans[i].c[2] + 6.0 * spans[i].c[3]) / (h0 * h0);
        const dvec3 d2b = 2.0 * spans[i + 1].c[2] / (h1 * h1);
        EXPECT_LT(glm::length(d2a - d2b), 1e-9);
    }
    EXPECT_LT(glm::length(spans.front().c[2]), 1e-12);  // natural end: C''(t_0) = 0
}

TEST(CubicTrajectory, CollinearPointsGiveAStraightLine) {
    const std::vector<dvec3> p = {{0, 0, 0}, {1, 0, 0}, {3, 0, 0}};
    const auto spans = interpolate_cubic(p, chord_length_knots(p));
    for (const auto& s : spans)
        for (double u = 0; u <= 1.0; u += 0.125) {
            EXPECT_NEAR(s.value(u).y, 0.0, 1e-12);
            EXPECT_NEAR(s.derivative(u).x, s.derivative(0).x, 1e-12);  // constant speed
        }
}

TEST(CubicTrajectory, CoincidentCentersAreRefused) {
    EXPECT_THROW(chord_length_knots({{0, 0, 0}, {0, 0, 0}}), InvalidInput);
}

TEST(QuadraticHalfAxes, CardinalBasisInterpolatesAndSumsToOne) {
    for (int n : {1, 2, 3, 6}) {
        std::vector<double> t;
        for (int i = 0; i <= n; ++i) t.push_back(i * i * 0.3 + i);
        const QuadraticCardinalBasis basis(t);
        for (int i = 0; i <= n; ++i) {
            const int span = i < n ? i : n - 1;
            const double u = i < n ? 0.0 : 1.0;
            for (int k = 0; k <= n; ++k)
                EXPECT_NEAR(basis.phi(k, span, u), i == k ? 1.0 : 0.0, 1e-12) << n << " " << i << " " << k;
        }
        for (int s = 0; s < n; ++s)
            for (double u : {0.1, 0.49, 0.5, 0.77}) {
                double sum = 0;
                for (int k = 0; k <= n; ++k) sum += basis.phi(k, s, u);
                EXPECT_NEAR(sum, 1.0, 1e-12);
            }
    }
}

TEST(QuadraticHalfAxes, ReproducesQuadraticData) {
    // A quadratic spline reproduces a quadratic polynomial exactly.
    const std::vector<double> t = {0, 0.5, 1.7, 2.0, 3.1};
    const QuadraticCardinalBasis basis(t);
    std::vector<double> v;
    for (double x : t) v.push_back(1 + 2 * x - 0.3 * x * x);
    for (int s = 0; s + 1 < static_cast<int>(t.size()); ++s)
        for (double u : {0.0, 0.3, 0.5, 0.9}) {
            const double x = t[s] + u * (t[s + 1] - t[s]);
            EXPECT_NEAR(basis.evaluate(v.data(), s, u), 1 + 2 * x - 0.3 * x * x, 1e-12);
        }
}

}  // namespace
}  // namespace sd
