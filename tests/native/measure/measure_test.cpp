// The measurement ABI used by the demo's report: analytic cases.
#include "sweepdeform/sweepdeform.h"

#include <gtest/gtest.h>

#include <cmath>
#include <vector>

namespace {

/// A UV sphere of radius r: closed, outward-facing.
void uv_sphere(double r, int rings, int segments, std::vector<float>& p, std::vector<int32_t>& t) {
    p = {0, 0, float(r)};
    for (int i = 1; i < rings; ++i)
        for (int j = 0; j < segments; ++j) {
            const double th = M_PI * i / rings, ph = 2 * M_PI * j / segments;
            p.insert(p.end(), {float(r * std::sin(th) * std::cos(ph)), float(r * std::sin(th) * std::sin(ph)),
                               float(r * std::cos(th))});
        }
    p.insert(p.end(), {0, 0, float(-r)});
    const int south = static_cast<int>(p.size() / 3) - 1;
    const auto ring = [&](int i, int j) { return 1 + (i - 1) * segments + (j % segments); };
    for (int j = 0; j < segments; ++j) t.insert(t.end(), {0, ring(1, j), ring(1, j + 1)});
    for (int i = 1; i + 1 < rings; ++i)
        for (int j = 0; j < segments; ++j) {
            t.insert(t.end(), {ring(i, j), ring(i + 1, j), ring(i + 1, j + 1)});
            t.insert(t.end(), {ring(i, j), ring(i + 1, j + 1), ring(i, j + 1)});
        }
    for (int j = 0; j < segments; ++j) t.insert(t.end(), {south, ring(rings - 1, j + 1), ring(rings - 1, j)});
}

TEST(Measure, SphereVolumeAndEquatorSection) {
    std::vector<float> p;
    std::vector<int32_t> t;
    uv_sphere(0.5, 64, 128, p, t);
    const int V = static_cast<int>(p.size() / 3), T = static_cast<int>(t.size() / 3);
    double v = 0;
    ASSERT_EQ(sd_measure_volume(V, p.data(), T, t.data(), &v), SD_OK) << sd_last_error();
    EXPECT_NEAR(v / (4.0 / 3.0 * M_PI * 0.125), 1.0, 2e-3);  // polygonal sphere: slightly less
    EXPECT_LT(v, 4.0 / 3.0 * M_PI * 0.125);
    const float points[6] = {0, 0, 0, 0.1f, 0, 0.2f}, normals[6] = {0, 0, 1, 1, 0, 0};
    double areas[2] = {0, 0};
    ASSERT_EQ(sd_measure_cross_sections(V, p.data(), T, t.data(), 2, points, normals, 0.0f, areas), SD_OK)
        << sd_last_error();
    EXPECT_NEAR(areas[0] / (M_PI * 0.25), 1.0, 2e-3);  // the equator
    const double r2 = 0.25 - 0.01;                     // plane x = 0.1
    EXPECT_NEAR(areas[1] / (M_PI * r2), 1.0, 5e-3);
}

TEST(Measure, CountsIntersectingPairsExactly) {
    // Two spheres: apart, then overlapping.
    std::vector<float> a, b;
    std::vector<int32_t> ta, tb;
    uv_sphere(0.5, 12, 24, a, ta);
    uv_sphere(0.5, 12, 24, b, tb);
    const int V = static_cast<int>(a.size() / 3);
    const auto both = [&](float dx, std::vector<float>& p, std::vector<int32_t>& t) {
        p = a;
        for (size_t i = 0; i < b.size(); i += 3) p.insert(p.end(), {b[i] + dx, b[i + 1], b[i + 2]});
        t = ta;
        for (int32_t i : tb) t.push_back(i + V);
    };
    std::vector<float> p;
    std::vector<int32_t> t;
    int64_t pairs = -1;
    both(1.2f, p, t);
    ASSERT_EQ(
        sd_measure_intersections(2 * V, p.data(), static_cast<int32_t>(t.size() / 3), t.data(), 0, nullptr, &pairs),
        SD_OK);
    EXPECT_EQ(pairs, 0);
    both(0.8f, p, t);
    ASSERT_EQ(
        sd_measure_intersections(2 * V, p.data(), static_cast<int32_t>(t.size() / 3), t.data(), 0, nullptr, &pairs),
        SD_OK);
    EXPECT_GT(pairs, 20);  // a circle of contact crosses many triangle pairs
    // Restricted to the first sphere's triangles only: a closed sphere does not cut itself.
    std::vector<int32_t> first(ta.size() / 3);
    for (size_t i = 0; i < first.size(); ++i) first[i] = static_cast<int32_t>(i);
    ASSERT_EQ(sd_measure_intersections(2 * V, p.data(), static_cast<int32_t>(t.size() / 3), t.data(),
                                       static_cast<int32_t>(first.size()), first.data(), &pairs),
              SD_OK);
    EXPECT_EQ(pairs, 0);
}

TEST(Measure, BadMeshesAreRefused) {
    std::vector<float> p = {0, 0, 0, 1, 0, 0, 0, 1, 0};
    std::vector<int32_t> t = {0, 1, 3};
    double v = 0;
    EXPECT_EQ(sd_measure_volume(3, p.data(), 1, t.data(), &v), SD_ERR_INVALID_ARGUMENT);
    t = {0, 1, 2};
    p[4] = NAN;
    EXPECT_EQ(sd_measure_volume(3, p.data(), 1, t.data(), &v), SD_ERR_INVALID_ARGUMENT);
    EXPECT_NE(std::string(sd_last_error()).find("vertex 1"), std::string::npos);
}

}  // namespace
