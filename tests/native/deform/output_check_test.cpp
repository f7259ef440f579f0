// The output check (issue 15) through the C ABI only (sd_output_check_*): an analytic case on
// two bones along +Y whose every ratio is known by hand, the frame's verdict and worst vertex,
// the nearer of two bones, segment clamping, the floor, non-finite vertices, the linear-blend
// fallback; a rigid motion of everything changes no ratio; 20,000 random vertices (several
// parallel blocks) against a brute-force reference; bad inputs change nothing.
#include "sweepdeform/sweepdeform.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <random>
#include <vector>

namespace {

const float kNaN = std::numeric_limits<float>::quiet_NaN();

/// Column-major 4x4: rotation by `angle` about Z, then translation t.
std::vector<float> rz(float angle, float tx, float ty, float tz) {
    const float c = std::cos(angle), s = std::sin(angle);
    return {c, s, 0, 0, -s, c, 0, 0, 0, 0, 1, 0, tx, ty, tz, 1};
}

std::vector<float> concat(const std::vector<float>& a, const std::vector<float>& b) {
    std::vector<float> r = a;
    r.insert(r.end(), b.begin(), b.end());
    return r;
}

/// Two bones of length 1 along +Y: bone 0 from the origin, bone 1 from (0, 1, 0).
/// Vertices (rest):           skin                    rest distance
///   0  (0.3, 0.5, 0)          bone 0                  0.3
///   1  (0.3, 1.5, 0)          0.25 bone 0, 0.75 bone 1 0.3 (bone 1; bone 0 is 0.583 away)
///   2  (0, 2.4, 0)            bone 1                  0.4 (beyond its tail)
///   3  (0, 0, 0)              none                    -
///   4  (0.05, 0.5, 0)         bone 0                  0.05, floored to 5 % of the diagonal
/// The diagonal of the rest positions' box is |(0.3, 2.4, 0)| = sqrt(5.85).
struct TwoBones {
    std::vector<float> rest = concat(rz(0, 0, 0, 0), rz(0, 0, 1, 0));
    std::vector<float> lengths = {1.0f, 1.0f};
    std::vector<float> positions = {0.3f, 0.5f, 0, 0.3f, 1.5f, 0, 0, 2.4f, 0, 0, 0, 0, 0.05f, 0.5f, 0};
    std::vector<int32_t> ids = {0, -1, 0, 1, 1, -1, -1, -1, 0, -1};
    std::vector<float> weights = {1, 0, 0.25f, 0.75f, 1, 0, 0, 0, 1, 0};
    const double floor = 0.05 * std::sqrt(5.85);
    sd_output_check* check = nullptr;

    TwoBones() {
        EXPECT_EQ(sd_output_check_create(5, positions.data(), 2, rest.data(), lengths.data(), 2, ids.data(),
                                         weights.data(), 0.05f, &check),
                  SD_OK)
            << sd_last_error();
    }
    ~TwoBones() { sd_output_check_destroy(check); }

    struct Result {
        int32_t beyond = -7, vertex = -7, bone = -7;
        float worst = -7.0f;
        std::vector<float> ratios = std::vector<float>(5, -7.0f);
    };
    Result run(const std::vector<float>& pose, const std::vector<float>& deformed, float limit = 3.0f) const {
        Result r;
        EXPECT_EQ(sd_output_check_run(check, 2, pose.data(), 5, deformed.data(), limit, &r.beyond, &r.worst, &r.vertex,
                                      &r.bone, r.ratios.data()),
                  SD_OK)
            << sd_last_error();
        return r;
    }
};

// Bone 1 turned 90 degrees about Z at its head: its segment runs from (0, 1, 0) to (-1, 1, 0).
const std::vector<float> kBent = concat(rz(0, 0, 0, 0), rz(float(M_PI / 2), 0, 1, 0));

TEST(OutputCheck, RestPoseIsWithinTheBound) {
    TwoBones t;
    const auto r = t.run(t.rest, t.positions);
    EXPECT_EQ(r.beyond, 0);
    const float floored = float(0.05 / t.floor);
    const std::vector<float> expected = {1, 1, 1, 0, floored};
    for (int v = 0; v < 5; ++v) EXPECT_NEAR(r.ratios[v], expected[v], 1e-6) << "vertex " << v;
    EXPECT_EQ(r.vertex, -1);  // none beyond
    EXPECT_EQ(r.bone, -1);
    EXPECT_EQ(r.worst, 0.0f);
    // A tiny limit: every vertex off its bone is beyond, so the worst is the frame's largest.
    const auto all = t.run(t.rest, t.positions, 1e-30f);
    EXPECT_EQ(all.beyond, 4);
    EXPECT_EQ(all.vertex, 0);  // ratio 1 for vertices 0, 1, 2: the lowest index
    EXPECT_EQ(all.bone, 0);
    EXPECT_NEAR(all.worst, 1.0f, 1e-6);
}

TEST(OutputCheck, AnalyticFrameAgainstTheBound) {
    TwoBones t;
    // Each vertex where a rigid motion with its heaviest bone takes it, vertex 4 pushed off its
    // bone to 0.3 (ratio 0.3 / floor = 2.48), the unskinned one far away (never checked).
    std::vector<float> deformed = {0.3f, 0.5f, 0, -0.5f, 1.3f, 0, -1.4f, 1, 0, 100, 100, 100, 0.3f, 0.5f, 0};
    auto r = t.run(kBent, deformed);
    EXPECT_EQ(r.beyond, 0);
    const std::vector<double> expected = {1, 1, 1, 0, 0.3 / t.floor};
    for (int v = 0; v < 5; ++v) EXPECT_NEAR(r.ratios[v], expected[v], 1e-5) << "vertex " << v;
    EXPECT_EQ(r.vertex, -1);
    const auto all = t.run(kBent, deformed, 1e-30f);  // the frame's largest ratio
    EXPECT_EQ(all.beyond, 4);
    EXPECT_EQ(all.vertex, 4);
    EXPECT_EQ(all.bone, 0);
    EXPECT_NEAR(all.worst, 0.3 / t.floor, 1e-5);
    // The same frame against a bound of 2: vertex 4 alone is beyond.
    r = t.run(kBent, deformed, 2.0f);
    EXPECT_EQ(r.beyond, 1);
    EXPECT_EQ(r.vertex, 4);
    EXPECT_NEAR(r.worst, 0.3 / t.floor, 1e-5);

    // Vertex 0 at 1.0 from bone 0 (rest 0.3): 3.33 x, beyond 3.
    deformed[0] = 1.0f;
    r = t.run(kBent, deformed);
    EXPECT_EQ(r.beyond, 1);
    EXPECT_EQ(r.vertex, 0);
    EXPECT_EQ(r.bone, 0);
    EXPECT_NEAR(r.worst, 1.0 / 0.3, 1e-5);
    deformed[0] = 0.3f;

    // Vertex 1 (heaviest bone 1) at (-0.5, 0, 0): 1.0 from bone 1's segment (3.33 x) but 0.5
    // from bone 0 (1.67 x): the nearer bone counts, so it is within.
    deformed[3] = -0.5f, deformed[4] = 0.0f;
    r = t.run(kBent, deformed);
    EXPECT_EQ(r.beyond, 0);
    EXPECT_NEAR(r.ratios[1], 0.5 / 0.3, 1e-5);
    // At (-0.5, 2.2, 0): bone 1's segment ends at (-1, 1, 0) and bone 0's at (0, 1, 0); the
    // nearest points are inside bone 1 (t = 0.5: 1.2 away) and bone 0's tail (|(-0.5, 1.2)| = 1.3).
    deformed[4] = 2.2f;
    r = t.run(kBent, deformed);
    EXPECT_NEAR(r.ratios[1], 1.2 / 0.3, 1e-5);
    EXPECT_EQ(r.beyond, 1);
    EXPECT_EQ(r.vertex, 1);
    EXPECT_EQ(r.bone, 1);  // its heaviest skin bone
    deformed[3] = -0.5f, deformed[4] = 1.3f;

    // Vertex 2 past bone 1's tail: clamped to the tail (-1, 1, 0); 1.3 away is 3.25 x.
    deformed[6] = -2.3f;
    r = t.run(kBent, deformed);
    EXPECT_EQ(r.beyond, 1);
    EXPECT_EQ(r.vertex, 2);
    EXPECT_NEAR(r.worst, 1.3 / 0.4, 1e-5);
    deformed[6] = -1.4f;

    // A non-finite vertex is beyond, with an infinite ratio.
    deformed[7] = kNaN;
    r = t.run(kBent, deformed);
    EXPECT_EQ(r.beyond, 1);
    EXPECT_EQ(r.vertex, 2);
    EXPECT_EQ(r.bone, 1);
    EXPECT_TRUE(std::isinf(r.worst) && r.worst > 0);
    EXPECT_TRUE(std::isinf(r.ratios[2]));
}

TEST(OutputCheck, RigidMotionOfEverythingChangesNoRatio) {
    TwoBones t;
    const std::vector<float> m = rz(0.7f, 3.0f, -2.0f, 1.0f);
    std::vector<float> pose, moved;
    for (int b = 0; b < 2; ++b) {  // m * rest_b, column-major
        for (int c = 0; c < 4; ++c)
            for (int r = 0; r < 4; ++r) {
                float s = 0;
                for (int k = 0; k < 4; ++k) s += m[4 * k + r] * t.rest[16 * b + 4 * c + k];
                pose.push_back(s);
            }
    }
    for (int v = 0; v < 5; ++v)
        for (int r = 0; r < 3; ++r)
            moved.push_back(m[r] * t.positions[3 * v] + m[4 + r] * t.positions[3 * v + 1] +
                            m[8 + r] * t.positions[3 * v + 2] + m[12 + r]);
    const auto at_rest = t.run(t.rest, t.positions);
    const auto r = t.run(pose, moved);
    for (int v = 0; v < 5; ++v) EXPECT_NEAR(r.ratios[v], at_rest.ratios[v], 1e-5) << "vertex " << v;
    EXPECT_EQ(r.beyond, 0);
}

TEST(OutputCheck, LinearBlendFallback) {
    TwoBones t;
    std::vector<float> out(15, -7.0f);
    ASSERT_EQ(sd_output_check_linear_blend(t.check, 2, kBent.data(), 5, out.data()), SD_OK) << sd_last_error();
    // Vertex 1: 0.25 x itself (bone 0 at rest) + 0.75 x (-0.5, 1.3, 0) (bone 1's turn).
    const std::vector<float> expected = {0.3f, 0.5f, 0, -0.3f, 1.35f, 0, -1.4f, 1, 0, 0, 0, 0, 0.05f, 0.5f, 0};
    for (int i = 0; i < 15; ++i) EXPECT_NEAR(out[i], expected[i], 1e-6) << "value " << i;
}

/// The reference, by brute force in the test: the nearer of the two heaviest bones (the
/// earlier slot among equal weights), the floored rest distance, non-finite = infinite.
struct Reference {
    int beyond = 0, worst_vertex = -1;
    double worst = 0;
    std::vector<double> ratios;
    std::vector<int> heaviest;  // each vertex's heaviest skin bone (-1: none)
};

TEST(OutputCheck, ManyVerticesMatchABruteForceReference) {
    const int V = 20000, B = 3, S = 3;
    std::mt19937 rng(5);
    std::uniform_real_distribution<float> u(-1.0f, 1.0f), w01(0.0f, 1.0f);
    const std::vector<float> rest = concat(concat(rz(0, 0, 0, 0), rz(0, 0, 1, 0)), rz(float(M_PI / 2), 0, 2, 0));
    const std::vector<float> lengths = {1.0f, 1.0f, 0.5f};
    const std::vector<float> pose = concat(concat(rz(0.2f, 0, 0, 0), rz(0.9f, -0.2f, 1, 0)), rz(2.0f, -1, 1.5f, 0));
    std::vector<float> positions(3 * V), deformed(3 * V), weights(V * S);
    std::vector<int32_t> ids(V * S);
    for (int v = 0; v < V; ++v) {
        for (int k = 0; k < 3; ++k) positions[3 * v + k] = u(rng) * (k == 1 ? 1.5f : 0.5f) + (k == 1 ? 1.0f : 0.0f);
        for (int k = 0; k < 3; ++k) deformed[3 * v + k] = positions[3 * v + k] + 0.6f * u(rng);
        for (int s = 0; s < S; ++s) {
            ids[v * S + s] = (v + s) % 7 == 0 ? -1 : int32_t((v * 7 + s) % B);
            weights[v * S + s] = (v % 11 == 0) ? 0.0f : w01(rng);
        }
    }
    const auto distance = [&](const float* m, int b, const float* p) {
        double h[3], a[3], d[3], dd = 0, da = 0, aa = 0;
        for (int k = 0; k < 3; ++k) {
            h[k] = m[16 * b + 12 + k], a[k] = m[16 * b + 4 + k] * double(lengths[b]), d[k] = p[k] - h[k];
            da += d[k] * a[k], aa += a[k] * a[k];
        }
        const double t = std::clamp(da / aa, 0.0, 1.0);
        for (int k = 0; k < 3; ++k) dd += (d[k] - t * a[k]) * (d[k] - t * a[k]);
        return std::sqrt(dd);
    };
    double lo[3] = {1e30, 1e30, 1e30}, hi[3] = {-1e30, -1e30, -1e30};
    for (int v = 0; v < V; ++v)
        for (int k = 0; k < 3; ++k)
            lo[k] = std::min(lo[k], double(positions[3 * v + k])),
            hi[k] = std::max(hi[k], double(positions[3 * v + k]));
    const double floor = 0.05 * std::sqrt((hi[0] - lo[0]) * (hi[0] - lo[0]) + (hi[1] - lo[1]) * (hi[1] - lo[1]) +
                                          (hi[2] - lo[2]) * (hi[2] - lo[2]));
    const auto reference = [&](const std::vector<float>& out, double limit) {
        Reference ref;
        ref.ratios.assign(V, 0.0);
        ref.heaviest.assign(V, -1);
        for (int v = 0; v < V; ++v) {
            std::vector<std::pair<float, int>> skin;  // (weight, slot) of the vertex's used slots
            for (int s = 0; s < S; ++s)
                if (ids[v * S + s] >= 0 && weights[v * S + s] > 0) skin.push_back({weights[v * S + s], s});
            if (skin.empty()) continue;
            std::stable_sort(skin.begin(), skin.end(), [](auto a, auto b) { return a.first > b.first; });
            const int b0 = ids[v * S + skin[0].second], b1 = skin.size() > 1 ? ids[v * S + skin[1].second] : b0;
            ref.heaviest[v] = b0;
            const double rest_d = std::max(floor, std::min(distance(rest.data(), b0, &positions[3 * v]),
                                                           distance(rest.data(), b1, &positions[3 * v])));
            double r =
                std::min(distance(pose.data(), b0, &out[3 * v]), distance(pose.data(), b1, &out[3 * v])) / rest_d;
            if (!std::isfinite(r)) r = std::numeric_limits<double>::infinity();
            ref.ratios[v] = r;
            if (r <= limit) continue;
            ++ref.beyond;
            if (ref.worst_vertex < 0 || r > ref.worst) ref.worst = r, ref.worst_vertex = v;
        }
        return ref;
    };
    sd_output_check* check = nullptr;
    ASSERT_EQ(sd_output_check_create(V, positions.data(), B, rest.data(), lengths.data(), S, ids.data(), weights.data(),
                                     0.05f, &check),
              SD_OK)
        << sd_last_error();
    for (const bool with_nan : {false, true}) {
        auto out = deformed;
        if (with_nan) out[3 * 12345 + 1] = kNaN;
        const Reference ref = reference(out, 1.5);
        ASSERT_GT(ref.beyond, 100);  // the case has vertices on both sides of the bound
        ASSERT_LT(ref.beyond, V - 100);
        int32_t beyond = -1, vertex = -1, bone = -1;
        float worst = -1;
        std::vector<float> ratios(V);
        ASSERT_EQ(sd_output_check_run(check, B, pose.data(), V, out.data(), 1.5f, &beyond, &worst, &vertex, &bone,
                                      ratios.data()),
                  SD_OK)
            << sd_last_error();
        EXPECT_EQ(beyond, ref.beyond) << "with NaN: " << with_nan;
        if (with_nan) {
            EXPECT_EQ(vertex, 12345);
            EXPECT_TRUE(std::isinf(worst));
        } else {
            EXPECT_NEAR(worst, ref.worst, 1e-5 * ref.worst);
            // The same vertex, or one whose ratio equals the worst to rounding.
            EXPECT_TRUE(vertex == ref.worst_vertex || std::abs(ref.ratios[vertex] - ref.worst) < 1e-9 * ref.worst)
                << vertex << " vs " << ref.worst_vertex;
        }
        ASSERT_GE(vertex, 0);
        EXPECT_EQ(bone, ref.heaviest[vertex]);
        for (int v = 0; v < V; ++v) {
            if (std::isinf(ref.ratios[v])) {
                EXPECT_TRUE(std::isinf(ratios[v])) << "vertex " << v;
            } else {
                EXPECT_NEAR(ratios[v], ref.ratios[v], 1e-5 * std::max(1.0, ref.ratios[v])) << "vertex " << v;
            }
        }
        // Without ratios (most vertices then pass on the bone nearer at rest alone): the same
        // verdict; and every output is optional.
        int32_t fast_beyond = -1, fast_vertex = -1;
        float fast_worst = -1;
        ASSERT_EQ(sd_output_check_run(check, B, pose.data(), V, out.data(), 1.5f, &fast_beyond, &fast_worst,
                                      &fast_vertex, nullptr, nullptr),
                  SD_OK);
        EXPECT_EQ(fast_beyond, beyond);
        EXPECT_EQ(fast_vertex, vertex);
        EXPECT_EQ(fast_worst, worst);
        ASSERT_EQ(sd_output_check_run(check, B, pose.data(), V, out.data(), 1.5f, nullptr, nullptr, nullptr, nullptr,
                                      nullptr),
                  SD_OK);
    }
    sd_output_check_destroy(check);
}

void expect_error(sd_status status, sd_status expected, const char* what) {
    EXPECT_EQ(status, expected) << what;
    EXPECT_GT(std::strlen(sd_last_error()), 10u) << what << ": the message explains the error";
}

TEST(OutputCheck, BadInputsAreRefusedAndChangeNothing) {
    TwoBones t;
    sd_output_check* c = nullptr;
    const auto create = [&](int32_t V, const float* pos, int32_t B, const float* rest, const float* len, int32_t S,
                            const int32_t* ids, const float* w, float floor_share) {
        return sd_output_check_create(V, pos, B, rest, len, S, ids, w, floor_share, &c);
    };
    const float* p = t.positions.data();
    const float* r = t.rest.data();
    const float* l = t.lengths.data();
    const int32_t* ids = t.ids.data();
    const float* w = t.weights.data();
    expect_error(create(0, p, 2, r, l, 2, ids, w, 0.05f), SD_ERR_INVALID_ARGUMENT, "no vertices");
    expect_error(create(5, nullptr, 2, r, l, 2, ids, w, 0.05f), SD_ERR_INVALID_ARGUMENT, "NULL positions");
    expect_error(create(5, p, 0, r, l, 2, ids, w, 0.05f), SD_ERR_INVALID_ARGUMENT, "no bones");
    expect_error(create(5, p, 2, nullptr, l, 2, ids, w, 0.05f), SD_ERR_INVALID_ARGUMENT, "NULL rest pose");
    expect_error(create(5, p, 2, r, nullptr, 2, ids, w, 0.05f), SD_ERR_INVALID_ARGUMENT, "NULL lengths");
    expect_error(create(5, p, 2, r, l, 2, nullptr, w, 0.05f), SD_ERR_INVALID_ARGUMENT, "NULL skin bones");
    expect_error(create(5, p, 2, r, l, -1, ids, w, 0.05f), SD_ERR_INVALID_ARGUMENT, "negative slots");
    expect_error(create(5, p, 2, r, l, 2, ids, w, 1.5f), SD_ERR_INVALID_ARGUMENT, "floor share above 1");
    expect_error(create(5, p, 2, r, l, 2, ids, w, kNaN), SD_ERR_INVALID_ARGUMENT, "NaN floor share");
    auto bad = t.positions;
    bad[4] = kNaN;
    expect_error(create(5, bad.data(), 2, r, l, 2, ids, w, 0.05f), SD_ERR_INVALID_ARGUMENT, "NaN rest position");
    auto bad_rest = t.rest;
    std::fill(bad_rest.begin() + 16, bad_rest.begin() + 28, 0.0f);
    expect_error(create(5, p, 2, bad_rest.data(), l, 2, ids, w, 0.05f), SD_ERR_INVALID_ARGUMENT, "singular rest");
    bad_rest = t.rest;
    bad_rest[3] = std::numeric_limits<float>::infinity();
    expect_error(create(5, p, 2, bad_rest.data(), l, 2, ids, w, 0.05f), SD_ERR_INVALID_ARGUMENT, "inf rest");
    auto bad_len = t.lengths;
    bad_len[1] = 0.0f;
    expect_error(create(5, p, 2, r, bad_len.data(), 2, ids, w, 0.05f), SD_ERR_INVALID_ARGUMENT, "zero length");
    auto bad_ids = t.ids;
    bad_ids[3] = 2;
    expect_error(create(5, p, 2, r, l, 2, bad_ids.data(), w, 0.05f), SD_ERR_INVALID_ARGUMENT, "bone out of range");
    auto bad_w = t.weights;
    bad_w[2] = -0.5f;
    expect_error(create(5, p, 2, r, l, 2, ids, bad_w.data(), 0.05f), SD_ERR_INVALID_ARGUMENT, "negative weight");
    expect_error(sd_output_check_create(5, p, 2, r, l, 2, ids, w, 0.05f, nullptr), SD_ERR_INVALID_ARGUMENT,
                 "NULL out_check");
    EXPECT_EQ(c, nullptr);  // no handle from a failed create

    // A frame: nothing is written on failure.
    int32_t beyond = -7, vertex = -7, bone = -7;
    float worst = -7.0f;
    std::vector<float> ratios(5, -7.0f), out(15, -7.0f);
    const auto run = [&](const sd_output_check* check, int32_t B, const float* pose, int32_t V, const float* pos,
                         float limit) {
        return sd_output_check_run(check, B, pose, V, pos, limit, &beyond, &worst, &vertex, &bone, ratios.data());
    };
    expect_error(run(nullptr, 2, r, 5, p, 3), SD_ERR_INVALID_ARGUMENT, "NULL check");
    expect_error(run(t.check, 3, r, 5, p, 3), SD_ERR_MISMATCH, "bone count");
    expect_error(run(t.check, 2, r, 4, p, 3), SD_ERR_MISMATCH, "vertex count");
    expect_error(run(t.check, 2, nullptr, 5, p, 3), SD_ERR_INVALID_ARGUMENT, "NULL pose");
    expect_error(run(t.check, 2, r, 5, nullptr, 3), SD_ERR_INVALID_ARGUMENT, "NULL positions");
    expect_error(run(t.check, 2, r, 5, p, 0), SD_ERR_INVALID_ARGUMENT, "zero limit");
    expect_error(run(t.check, 2, r, 5, p, kNaN), SD_ERR_INVALID_ARGUMENT, "NaN limit");
    auto bad_pose = t.rest;
    bad_pose[20] = kNaN;
    expect_error(run(t.check, 2, bad_pose.data(), 5, p, 3), SD_ERR_INVALID_ARGUMENT, "NaN pose");
    expect_error(sd_output_check_linear_blend(t.check, 2, bad_pose.data(), 5, out.data()), SD_ERR_INVALID_ARGUMENT,
                 "NaN pose (fallback)");
    expect_error(sd_output_check_linear_blend(t.check, 2, r, 6, out.data()), SD_ERR_MISMATCH,
                 "vertex count (fallback)");
    expect_error(sd_output_check_linear_blend(t.check, 2, r, 5, nullptr), SD_ERR_INVALID_ARGUMENT,
                 "NULL out (fallback)");
    EXPECT_EQ(beyond, -7);
    EXPECT_EQ(vertex, -7);
    EXPECT_EQ(bone, -7);
    EXPECT_EQ(worst, -7.0f);
    for (float x : ratios) EXPECT_EQ(x, -7.0f);
    for (float x : out) EXPECT_EQ(x, -7.0f);
    sd_output_check_destroy(nullptr);  // accepted, ignored
}

}  // namespace
