// Anatomical effects (Sect. 4.3, 4.4). Analytic cases first: exact predicates and the
// triangle–triangle test (crossing, touching, coplanar, disjoint, degenerate, one-ulp
// changes), the BVH query against brute force on random soups; then the synthetic arm of
// test_arm.h bent to 150 degrees (sweeps and linear blend skinning intersect, folding
// leaves none, the volume stays); then the characters of ../shared/data, fitted
// automatically, at elbow flexion 90/120/150 and knee flexion 90/135; and the C ABI.
#include "character_fit.h"
#include "anatomy/anatomy.h"
#include "geometry/bvh.h"
#include "geometry/cross_section.h"
#include "geometry/exact_predicates.h"
#include "geometry/mesh_topology.h"
#include "geometry/mesh_volume.h"
#include "geometry/self_intersection.h"
#include "geometry/triangle_intersection.h"
#include "fit/fit_rig.h"
#include "deform/linear_blend_skinning.h"
#include "test_arm.h"
#include "turned_pose.h"

#include "sweepdeform/sweepdeform.h"

#include <sweepdeform_io/animation.h>
#include <sweepdeform_io/gltf_loader.h>

#include <gtest/gtest.h>
#include <glm/gtc/matrix_transform.hpp>
#include <tbb/global_control.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <limits>
#include <random>

namespace sd::anatomy {
namespace {

// ---- exact predicates -------------------------------------------------------------------

TEST(ExactPredicates, SignsOfSimpleConfigurations) {
    const double a[3] = {0, 0, 0}, b[3] = {1, 0, 0}, c[3] = {0, 1, 0};
    const double up[3] = {0.3, 0.3, 1}, down[3] = {0.3, 0.3, -1}, on[3] = {5, -7, 0};
    EXPECT_EQ(orient3d(a, b, c, up), 1);
    EXPECT_EQ(orient3d(a, b, c, down), -1);
    EXPECT_EQ(orient3d(a, b, c, on), 0);
    EXPECT_EQ(orient2d(a, b, c), 1);
    EXPECT_EQ(orient2d(a, c, b), -1);
    const double m[3] = {0.5, 0, 0};
    EXPECT_EQ(orient2d(a, b, m), 0);
}

TEST(ExactPredicates, FilterAndExactAgreeOnNearlyDegenerateInput) {
    // Points on a tilted plane built from dyadic steps (exact in double), then moved off it
    // by one ulp: the double-precision determinant is pure round-off, the sign is not.
    std::mt19937 rng(7);
    std::uniform_int_distribution<int> step(-64, 64);
    int nonzero = 0;
    for (int trial = 0; trial < 2000; ++trial) {
        double a[3], u[3], v[3];
        for (int k = 0; k < 3; ++k) {
            a[k] = step(rng) / 16.0;
            u[k] = step(rng) / 32.0;
            v[k] = step(rng) / 32.0;
        }
        const double s = step(rng) / 64.0, t = step(rng) / 64.0;
        double b[3], c[3], d[3];
        for (int k = 0; k < 3; ++k) {
            b[k] = a[k] + u[k];
            c[k] = a[k] + v[k];
            d[k] = a[k] + s * u[k] + t * v[k];
        }
        EXPECT_EQ(orient3d(a, b, c, d), 0);
        EXPECT_EQ(detail::orient3d_exact(a, b, c, d), 0);
        d[2] = std::nextafter(d[2], 10.0);
        const int o = orient3d(a, b, c, d);
        EXPECT_EQ(o, detail::orient3d_exact(a, b, c, d));
        // The normal's z component decides the sign of a z-nudge.
        const double nz = u[0] * v[1] - u[1] * v[0];
        EXPECT_EQ(o, nz > 0 ? 1 : (nz < 0 ? -1 : 0));
        nonzero += o != 0;
    }
    EXPECT_GT(nonzero, 1000);
}

// ---- triangle–triangle ---------------------------------------------------------------

bool tt(std::initializer_list<double> p) {
    const std::vector<double> v(p);
    return triangles_intersect(&v[0], &v[3], &v[6], &v[9], &v[12], &v[15]);
}

TEST(TriangleIntersection, AnalyticCases) {
    // Crossing: a vertical triangle through the middle of a horizontal one.
    EXPECT_TRUE(tt({0, 0, 0, 2, 0, 0, 0, 2, 0, /**/ 0.5, 0.5, -1, 0.5, 0.5, 1, 1.5, 0.2, 0}));
    EXPECT_TRUE(tt({0, 0, 0, 4, 0, 0, 0, 4, 0, /**/ 1, 1, -1, 1, 1, 1, 1, 2, 1}));  // piercing edge
    // Touching: a vertex on the face, an edge on an edge, a vertex on a vertex.
    EXPECT_TRUE(tt({0, 0, 0, 2, 0, 0, 0, 2, 0, /**/ 0.5, 0.5, 0, 1, 1, 1, 0, 1, 2}));
    EXPECT_TRUE(tt({0, 0, 0, 2, 0, 0, 0, 2, 0, /**/ 1, -1, 0, 1, 1, 0, 1, 0,
                    1}));  // edge across the face, in the plane on one side
    EXPECT_TRUE(tt({0, 0, 0, 2, 0, 0, 0, 2, 0, /**/ 1, 0, 0, 1, -1, 1, 3, -1, 1}));  // vertex on an edge
    EXPECT_TRUE(tt({0, 0, 0, 2, 0, 0, 0, 2, 0, /**/ 2, 0, 0, 3, 0, 1, 3, 1, 1}));    // vertex on a vertex
    // Coplanar: overlapping, one inside the other, sharing only an edge segment, disjoint.
    EXPECT_TRUE(tt({0, 0, 0, 2, 0, 0, 0, 2, 0, /**/ 1, 1, 0, -1, 1, 0, 1, -1, 0}));
    EXPECT_TRUE(tt({0, 0, 0, 4, 0, 0, 0, 4, 0, /**/ 1, 1, 0, 2, 1, 0, 1, 2, 0}));
    EXPECT_TRUE(tt({0, 0, 0, 2, 0, 0, 0, 2, 0, /**/ 1, 0, 0, 3, 0, 0, 2, -1, 0}));
    EXPECT_FALSE(tt({0, 0, 0, 2, 0, 0, 0, 2, 0, /**/ 2, 2, 0, 3, 2, 0, 2, 3, 0}));
    EXPECT_FALSE(tt({0, 0, 0, 2, 0, 0, 0, 2, 0, /**/ 1.01, 1.01, 0, 3, 1, 0, 1, 3, 0}));  // just beyond the hypotenuse
    // Disjoint: parallel planes, separated in one axis, a near miss beside an edge.
    EXPECT_FALSE(tt({0, 0, 0, 2, 0, 0, 0, 2, 0, /**/ 0, 0, 1, 2, 0, 1, 0, 2, 1}));
    EXPECT_FALSE(tt({0, 0, 0, 2, 0, 0, 0, 2, 0, /**/ 5, 5, 5, 6, 5, 5, 5, 6, 5}));
    EXPECT_FALSE(tt({0, 0, 0, 2, 0, 0, 0, 2, 0, /**/ 1.5, 1.5, -1, 1.5, 1.5, 1, 2.5, 1.5, 0}));
    // Degenerate: a segment-triangle through the face, a point-triangle on the face, a
    // collinear triangle beside it, two crossing segment-triangles, two parallel ones.
    EXPECT_TRUE(tt({0, 0, 0, 2, 0, 0, 0, 2, 0, /**/ 0.5, 0.5, -1, 0.5, 0.5, 1, 0.5, 0.5, 0.5}));
    EXPECT_TRUE(tt({0, 0, 0, 2, 0, 0, 0, 2, 0, /**/ 0.5, 0.5, 0, 0.5, 0.5, 0, 0.5, 0.5, 0}));
    EXPECT_FALSE(tt({0, 0, 0, 2, 0, 0, 0, 2, 0, /**/ 3, 3, -1, 3, 3, 1, 3, 3, 0}));
    EXPECT_TRUE(tt({0, 0, 0, 2, 0, 0, 1, 0, 0, /**/ 1, -1, 0, 1, 1, 0, 1, 0.5, 0}));
    EXPECT_FALSE(tt({0, 0, 0, 2, 0, 0, 1, 0, 0, /**/ 0, 1, 0, 2, 1, 0, 1, 1, 0}));
    EXPECT_FALSE(tt({0, 0, 0, 2, 0, 0, 1, 0, 0, /**/ 3, 0, 0, 4, 0, 0, 5, 0, 0}));  // same line, apart
    EXPECT_TRUE(tt({0, 0, 0, 2, 0, 0, 1, 0, 0, /**/ 2, 0, 0, 4, 0, 0, 3, 0, 0}));   // same line, touching
}

TEST(TriangleIntersection, OneUlpDecidesTouchingVersusDisjoint) {
    // A tilted float triangle and a second triangle whose lowest vertex lies exactly on the
    // first one's face (dyadic coordinates, exact in float). Moving that vertex by one ulp
    // along the normal side turns "touching" into "disjoint", and towards the other side
    // into "crossing"; a tolerance-based test cannot tell these apart.
    const float a[3] = {0.125f, 0.25f, 0.5f}, b[3] = {1.125f, 0.5f, 0.625f}, c[3] = {0.375f, 1.25f, 0.75f};
    float on[3];
    for (int k = 0; k < 3; ++k) on[k] = a[k] + 0.25f * (b[k] - a[k]) + 0.25f * (c[k] - a[k]);
    const double ad[3] = {a[0], a[1], a[2]}, bd[3] = {b[0], b[1], b[2]}, cd[3] = {c[0], c[1], c[2]};
    const double ond[3] = {on[0], on[1], on[2]};
    ASSERT_EQ(orient3d(ad, bd, cd, ond), 0);
    // The normal of (a, b, c) has a positive z component: "up" is the outside.
    const float top1[3] = {on[0] + 0.5f, on[1], on[2] + 1.0f}, top2[3] = {on[0], on[1] + 0.5f, on[2] + 1.0f};
    EXPECT_TRUE(triangles_intersect(a, b, c, on, top1, top2));
    float up[3] = {on[0], on[1], std::nextafter(on[2], 10.0f)};
    EXPECT_FALSE(triangles_intersect(a, b, c, up, top1, top2));
    float down[3] = {on[0], on[1], std::nextafter(on[2], -10.0f)};
    EXPECT_TRUE(triangles_intersect(a, b, c, down, top1, top2));
}

// An independent reference for random soups of small-integer triangles: two closed
// triangles meet iff an edge of one meets the other, decided from distances computed in
// double (for small integers a non-zero distance is far above round-off).
using V3 = std::array<double, 3>;
V3 sub(const V3& a, const V3& b) { return {a[0] - b[0], a[1] - b[1], a[2] - b[2]}; }
V3 add(const V3& a, const V3& b) { return {a[0] + b[0], a[1] + b[1], a[2] + b[2]}; }
V3 mul(const V3& a, double s) { return {a[0] * s, a[1] * s, a[2] * s}; }
double dot(const V3& a, const V3& b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }
V3 cross(const V3& a, const V3& b) {
    return {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
}

/// Squared distance between segments (Ericson, Real-Time Collision Detection, 5.1.9).
double segment_segment_d2(const V3& p1, const V3& q1, const V3& p2, const V3& q2) {
    const V3 d1 = sub(q1, p1), d2 = sub(q2, p2), r = sub(p1, p2);
    const double a = dot(d1, d1), e = dot(d2, d2), f = dot(d2, r);
    double s, t;
    if (a <= 0 && e <= 0) return dot(r, r);
    if (a <= 0) {
        s = 0;
        t = std::clamp(f / e, 0.0, 1.0);
    } else {
        const double c = dot(d1, r);
        if (e <= 0) {
            t = 0;
            s = std::clamp(-c / a, 0.0, 1.0);
        } else {
            const double b = dot(d1, d2), denom = a * e - b * b;
            s = denom != 0 ? std::clamp((b * f - c * e) / denom, 0.0, 1.0) : 0.0;
            t = (b * s + f) / e;
            if (t < 0) {
                t = 0;
                s = std::clamp(-c / a, 0.0, 1.0);
            } else if (t > 1) {
                t = 1;
                s = std::clamp((b - c) / a, 0.0, 1.0);
            }
        }
    }
    const V3 d = sub(add(p1, mul(d1, s)), add(p2, mul(d2, t)));
    return dot(d, d);
}

bool reference_segment_meets_triangle(const V3& a, const V3& b, const V3 (&t)[3]) {
    const double tiny = 1e-12;
    for (int j = 0; j < 3; ++j)
        if (segment_segment_d2(a, b, t[j], t[(j + 1) % 3]) < tiny) return true;
    const V3 n = cross(sub(t[1], t[0]), sub(t[2], t[0]));
    if (dot(n, n) == 0) return false;  // degenerate: its edges were all the triangle
    const double da = dot(n, sub(a, t[0])), db = dot(n, sub(b, t[0]));
    if ((da > 0 && db > 0) || (da < 0 && db < 0)) return false;
    if (da == 0 && db == 0) {
        // In the plane, not touching an edge: inside iff an endpoint is inside.
        const V3& p = a;
        const double s0 = dot(n, cross(sub(t[1], t[0]), sub(p, t[0])));
        const double s1 = dot(n, cross(sub(t[2], t[1]), sub(p, t[1])));
        const double s2 = dot(n, cross(sub(t[0], t[2]), sub(p, t[2])));
        return s0 >= 0 && s1 >= 0 && s2 >= 0;
    }
    const V3 p = add(a, mul(sub(b, a), da / (da - db)));
    const double s0 = dot(n, cross(sub(t[1], t[0]), sub(p, t[0])));
    const double s1 = dot(n, cross(sub(t[2], t[1]), sub(p, t[1])));
    const double s2 = dot(n, cross(sub(t[0], t[2]), sub(p, t[2])));
    const double scale = dot(n, n) * 1e-9;
    return s0 >= -scale && s1 >= -scale && s2 >= -scale;
}

bool reference_triangles_meet(const V3 (&t)[3], const V3 (&u)[3]) {
    for (int i = 0; i < 3; ++i) {
        if (reference_segment_meets_triangle(t[i], t[(i + 1) % 3], u)) return true;
        if (reference_segment_meets_triangle(u[i], u[(i + 1) % 3], t)) return true;
    }
    return false;
}

TEST(TriangleIntersection, MatchesAnIndependentReferenceOnIntegerSoups) {
    // Coordinates in -3..3: coplanar, touching and degenerate configurations are frequent.
    std::mt19937 rng(12345);
    std::uniform_int_distribution<int> coord(-3, 3);
    int hits = 0, coplanar = 0, degenerate = 0;
    for (int trial = 0; trial < 200000; ++trial) {
        V3 t[3], u[3];
        double tf[9], uf[9];
        for (int i = 0; i < 3; ++i)
            for (int k = 0; k < 3; ++k) {
                t[i][k] = tf[3 * i + k] = coord(rng);
                u[i][k] = uf[3 * i + k] = coord(rng);
            }
        if (trial % 5 == 0)  // force a shared plane z = 0
            for (int i = 0; i < 3; ++i) t[i][2] = tf[3 * i + 2] = u[i][2] = uf[3 * i + 2] = 0;
        const bool want = reference_triangles_meet(t, u);
        const bool got = triangles_intersect(&tf[0], &tf[3], &tf[6], &uf[0], &uf[3], &uf[6]);
        ASSERT_EQ(got, want) << "trial " << trial;
        const bool got_swapped = triangles_intersect(&uf[0], &uf[3], &uf[6], &tf[0], &tf[3], &tf[6]);
        ASSERT_EQ(got_swapped, want) << "trial " << trial << " (swapped)";
        hits += want;
        coplanar += trial % 5 == 0;
        const V3 n = cross(sub(t[1], t[0]), sub(t[2], t[0]));
        degenerate += dot(n, n) == 0;
    }
    std::printf("integer soup: 200000 pairs, %d intersecting, %d coplanar, %d degenerate\n", hits, coplanar,
                degenerate);
    EXPECT_GT(hits, 10000);
    EXPECT_GT(degenerate, 1000);
}

// ---- BVH against brute force -----------------------------------------------------------

struct Soup {
    std::vector<float> positions;
    MeshTopology mesh;
    std::vector<int32_t> all;
};

/// n triangles with random corners near random centres in a unit cube (each triangle has its
/// own vertices, so no pair shares one).
Soup random_soup(int n, float size, unsigned seed) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> unit(0.0f, 1.0f), off(-size, size);
    Soup s;
    std::vector<int32_t> tris;
    for (int t = 0; t < n; ++t) {
        const float c[3] = {unit(rng), unit(rng), unit(rng)};
        for (int i = 0; i < 3; ++i) {
            for (int k = 0; k < 3; ++k) s.positions.push_back(c[k] + off(rng));
            tris.push_back(3 * t + i);
        }
    }
    s.mesh = MeshTopology::build(3 * n, tris.data(), n, s.positions.data());
    for (int t = 0; t < n; ++t) s.all.push_back(t);
    return s;
}

TEST(SelfIntersection, BvhFindsExactlyTheBruteForcePairsOnRandomSoups) {
    for (unsigned seed : {1u, 2u, 3u}) {
        Soup s = random_soup(3000, 0.04f, seed);
        std::vector<TrianglePair> brute, bvh, bvh_serial, bvh_no_cones;
        brute_force_pairs(s.mesh, s.all, s.positions.data(), brute);
        CpuCollisionBackend cpu;
        cpu.set_triangles(s.mesh, s.all, s.positions.data());
        cpu.find_pairs(s.positions.data(), bvh);
        CpuCollisionBackend serial({true, 4, false});
        serial.set_triangles(s.mesh, s.all, s.positions.data());
        serial.find_pairs(s.positions.data(), bvh_serial);
        CpuCollisionBackend plain({false, 8, true});
        plain.set_triangles(s.mesh, s.all, s.positions.data());
        plain.find_pairs(s.positions.data(), bvh_no_cones);
        std::printf("soup %u: 3000 triangles, %zu intersecting pairs (brute force), %lld exact tests by the BVH\n",
                    seed, brute.size(), static_cast<long long>(cpu.last_stats().triangle_tests));
        EXPECT_GT(brute.size(), 50u);
        EXPECT_EQ(bvh, brute);
        EXPECT_EQ(bvh_serial, brute);
        EXPECT_EQ(bvh_no_cones, brute);

        // Move a third of the triangles, then ask only about the moved ones.
        std::vector<int32_t> moved;
        for (int t = 0; t < 3000; t += 3) {
            moved.push_back(t);
            for (int i = 0; i < 3; ++i) s.positions[3 * (3 * t + i) + 0] += 0.05f;
        }
        brute_force_pairs(s.mesh, s.all, s.positions.data(), brute);
        std::vector<TrianglePair> touching, expected;
        cpu.find_pairs_touching(s.positions.data(), moved, touching);
        for (const TrianglePair& p : brute)
            if (p.a % 3 == 0 || p.b % 3 == 0) expected.push_back(p);
        EXPECT_EQ(touching, expected);
        cpu.find_pairs(s.positions.data(), bvh);
        EXPECT_EQ(bvh, brute);
    }
}

// ---- helpers for bent limbs ----------------------------------------------------------

dvec3 at(const std::vector<float>& p, int v) { return dvec3(p[3 * v], p[3 * v + 1], p[3 * v + 2]); }

/// The farthest any vertex of `p` lies from its place in `q` (same vertex count).
double largest_move(const std::vector<float>& p, const std::vector<float>& q) {
    double worst = 0.0;
    for (int v = 0; v < static_cast<int>(p.size() / 3); ++v) worst = std::max(worst, glm::length(at(p, v) - at(q, v)));
    return worst;
}

/// Posed matrices (#B*16) of `skeleton` with the subtree of `lower` turned about the joint so
/// that the angle between the upper link and the lower link becomes `flexion` (radians), the
/// lower link moving towards `towards` (the front for an elbow, the back for a knee).
std::vector<float> flex_pose(const Skeleton& sk, int upper, int lower, const dvec3& towards, double flexion) {
    const dvec3 joint = sk.heads[lower];
    const dvec3 u = glm::normalize(sk.tails[upper] - sk.heads[upper]);
    const dvec3 f = glm::normalize(towards - glm::dot(towards, u) * u);
    const dvec3 axis = glm::cross(u, f);
    const dvec3 l = glm::normalize(sk.tails[lower] - sk.heads[lower]);
    const double rest = std::atan2(glm::dot(l, f), glm::dot(l, u));
    return testing::turned_pose(sk, lower, testing::turn_about(joint, axis, flexion - rest));
}

/// The pairs of `pairs` with both triangles in `region` (sorted ids).
size_t pairs_within(const std::vector<TrianglePair>& pairs, const std::vector<int32_t>& region) {
    size_t n = 0;
    for (const TrianglePair& p : pairs)
        n += std::binary_search(region.begin(), region.end(), p.a) &&
             std::binary_search(region.begin(), region.end(), p.b);
    return n;
}

// ---- the synthetic arm ------------------------------------------------------------------

/// The arm's sweeps with the anatomical effects at its elbow (folding towards the front, +y).
struct ArmWithElbowEffects {
    Binding binding;
    std::vector<int32_t> triangles;
    Anatomy anatomy;
    Deformer deformer;

    explicit ArmWithElbowEffects(const test::Arm& arm)
        : binding(arm.bind()),
          triangles(arm.ring_triangles()),
          anatomy(arm.rig, binding, triangles.data(), static_cast<int>(triangles.size() / 3)),
          deformer(arm.rig, binding) {
        const dvec3 front(0, 1, 0);
        anatomy.add_joint(1, JointKind::Elbow, &front);
    }
    /// One frame for the posed bone matrices `pose`.
    std::vector<float> deform(const std::vector<float>& pose) {
        std::vector<float> out(binding.rest_positions.size());
        anatomy.deform(deformer, pose.data(), out.data());
        return out;
    }
};

TEST(Anatomy, RestPoseIsUntouched) {
    const test::Arm arm;
    ArmWithElbowEffects fx(arm);
    const Anatomy& anatomy = fx.anatomy;
    EXPECT_LE(largest_move(fx.deform(arm.pose(0.0)), arm.mesh), 1e-6);
    EXPECT_EQ(anatomy.stats().pairs_before, 0);
    EXPECT_EQ(anatomy.stats().protrusion_vertices, 0);
    EXPECT_EQ(anatomy.stats().bulge_vertices, 0);
}

TEST(Anatomy, TheRestMeshsOwnIntersectionsAreLeftAsTheyAre) {
    // A model may intersect itself at rest (a low-poly body's overlapping faces, a belt through
    // the waist): one vertex at the elbow pushed through the tube to its far side. Folding
    // takes such pairs for the model's, not for contact a pose made, so the rest pose is
    // reproduced (folding them moved CesiumMan's knees 5 cm at rest).
    test::Arm arm;
    const int spike = 24 * arm.ring_size;  // ring 24 (x = 1, the elbow), its vertex at +y
    arm.mesh[3 * spike + 1] = static_cast<float>(-1.5 * test::Arm::kA);
    ArmWithElbowEffects fx(arm);
    Anatomy& anatomy = fx.anatomy;
    const std::vector<float> out = fx.deform(arm.pose(0.0));
    ASSERT_GT(anatomy.count_intersections(arm.mesh.data()), 0) << "the spike must cross the tube at rest";
    EXPECT_LE(largest_move(out, arm.mesh), 1e-6);
    EXPECT_EQ(anatomy.stats().pairs_before, 0);
    // Bent, the inside of the elbow still folds: contact the pose made is resolved.
    fx.deform(arm.pose(glm::radians(150.0)));
    EXPECT_GT(anatomy.stats().pairs_before, 0);
    EXPECT_EQ(anatomy.stats().pairs_after, 0);
}

TEST(Anatomy, BentTubeIntersectsWithSweepsAndLinearBlendSkinningButNotAfterFolding) {
    const test::Arm arm;
    const Binding binding = arm.bind();
    const std::vector<int32_t> tris = arm.ring_triangles();
    const int T = static_cast<int>(tris.size() / 3), V = arm.vertex_count();
    const MeshTopology mesh = MeshTopology::build(V, tris.data(), T, arm.mesh.data());
    std::vector<int32_t> all(T);
    for (int t = 0; t < T; ++t) all[t] = t;
    const auto pose = arm.pose(glm::radians(150.0));

    // Plain sweeps.
    Deformer plain(arm.rig, binding);
    std::vector<float> sweep(arm.mesh.size());
    plain.deform(pose.data(), sweep.data());
    std::vector<TrianglePair> brute, bvh;
    brute_force_pairs(mesh, all, sweep.data(), brute);
    // The BVH with normal-cone culling finds exactly the same pairs on this folded mesh.
    CpuCollisionBackend cpu;
    cpu.set_triangles(mesh, all, arm.mesh.data());
    cpu.find_pairs(sweep.data(), bvh);
    EXPECT_EQ(bvh, brute);
    const size_t sweep_pairs = brute.size();

    // Linear blend skinning, weights ramping over the elbow.
    std::vector<int32_t> joints(4 * V, 0);
    std::vector<float> weights(4 * V, 0.0f), lbs(arm.mesh.size());
    for (int v = 0; v < V; ++v) {
        const float w = static_cast<float>(std::clamp((arm.mesh[3 * v] - 0.85) / 0.3, 0.0, 1.0));
        joints[4 * v] = 0;
        joints[4 * v + 1] = 1;
        weights[4 * v] = 1.0f - w;
        weights[4 * v + 1] = w;
    }
    SkeletonPose sp;
    sp.set(arm.rig.skeleton, pose.data());
    skin_linear_blend4(bone_affines(sp), V, arm.mesh.data(), joints.data(), weights.data(), lbs.data());
    brute_force_pairs(mesh, all, lbs.data(), brute);
    const size_t lbs_pairs = brute.size();

    // Sweeps with the anatomical effects, the pose held for a few frames (volume feedback).
    ArmWithElbowEffects fx(arm);
    Anatomy& anatomy = fx.anatomy;
    std::vector<float> out;
    for (int frame = 0; frame < 10; ++frame) out = fx.deform(pose);
    brute_force_pairs(mesh, all, out.data(), brute);
    const ClosedRegion tube(mesh, all);
    const double v0 = tube.volume(arm.mesh.data());
    const double v_sweep = tube.volume(sweep.data()) / v0 - 1.0, v_anat = tube.volume(out.data()) / v0 - 1.0;
    const AnatomyStats& st = anatomy.stats();
    std::printf(
        "bent tube 150 deg: intersecting pairs: sweeps %zu, linear blend skinning %zu, after folding %zu "
        "(%d before folding this frame, %d passes); volume vs rest: sweeps %+.2f %%, with effects %+.2f %%\n",
        sweep_pairs, lbs_pairs, brute.size(), st.pairs_before, st.folding_iterations, 100 * v_sweep, 100 * v_anat);
    EXPECT_GT(sweep_pairs, 0u);
    EXPECT_GT(lbs_pairs, 0u);
    EXPECT_EQ(brute.size(), 0u);
    EXPECT_EQ(anatomy.count_intersections(out.data()), 0);
    EXPECT_LT(std::abs(v_anat), 0.01);
}

TEST(Anatomy, ResultDoesNotDependOnTheThreadCount) {
    const test::Arm arm;
    const auto pose = arm.pose(glm::radians(150.0));
    std::vector<float> out[2];
    for (int threads : {1, 2}) {
        tbb::global_control c(tbb::global_control::max_allowed_parallelism, threads);
        ArmWithElbowEffects fx(arm);
        for (int frame = 0; frame < 4; ++frame) out[threads - 1] = fx.deform(pose);
    }
    EXPECT_EQ(out[0], out[1]);
}

TEST(Anatomy, InFrameFramesDependOnThePoseOnly) {
    const test::Arm arm;
    const auto make = [&](std::vector<double> history) {
        ArmWithElbowEffects fx(arm);
        fx.anatomy.set_volume_feedback(VolumeFeedback::InFrame);
        std::vector<float> out;
        history.push_back(150.0);
        for (double deg : history) out = fx.deform(arm.pose(glm::radians(deg)));
        return out;
    };
    EXPECT_EQ(make({}), make({90.0, 120.0, 40.0}));
}

TEST(Anatomy, InFrameFeedbackLandsWhereAHeldPoseSettles) {
    // One frame with the feedback in the frame (one pass of the effects, the sweeps again with
    // that frame's I_C) against the paper's feedback, frame to frame, the pose held until it
    // settles: the same skin to a small part of the arm's radius, in one pass of the effects.
    const test::Arm arm;
    const auto pose = arm.pose(glm::radians(150.0));
    ArmWithElbowEffects held(arm);
    held.anatomy.set_volume_feedback(VolumeFeedback::NextFrame);
    std::vector<float> settled;
    for (int frame = 0; frame < 30; ++frame) settled = held.deform(pose);
    ArmWithElbowEffects now(arm);
    now.anatomy.set_volume_feedback(VolumeFeedback::InFrame);
    const std::vector<float> one = now.deform(pose);
    EXPECT_EQ(now.anatomy.stats().passes, 1);
    EXPECT_GT(std::abs(now.anatomy.stats().volume_change), 0.0);  // the effects changed the volume
    ArmWithElbowEffects none(arm);
    none.anatomy.set_volume_feedback(VolumeFeedback::Off);
    const std::vector<float> uncorrected = none.deform(pose);
    const auto rms = [](const std::vector<float>& p, const std::vector<float>& q) {
        double sum = 0.0;
        for (size_t i = 0; i < p.size(); ++i) sum += (double(p[i]) - q[i]) * (double(p[i]) - q[i]);
        return std::sqrt(sum / double(p.size() / 3));
    };
    const double apart = rms(one, settled), without = rms(uncorrected, settled);
    std::printf("arm at 150 deg (half-axes %.2f, %.2f): in-frame vs settled %.2e, without feedback vs settled %.2e\n",
                test::Arm::kA, test::Arm::kB, apart, without);
    EXPECT_LT(apart, 0.5 * without);
}

TEST(Anatomy, ProxyMeshesMustBeClosedAndStarShaped) {
    const dmat3 axes(1.0);
    ProxyShape ok = ellipsoid_shape(dvec3(0.0), axes, dvec3(0.1, 0.2, 0.3), 1);
    EXPECT_NO_THROW(BoneProxy(0, 1.0, ok, "ellipsoid"));
    BoneProxy proxy(0, 1.0, ok, "ellipsoid");
    EXPECT_TRUE(proxy.contains(dvec3(0.05, 0.0, 0.0)));
    EXPECT_FALSE(proxy.contains(dvec3(0.12, 0.0, 0.0)));
    EXPECT_NEAR(proxy.surface_distance(dvec3(0, 0, 1)), 0.3, 1e-6);
    ProxyShape open = ok;
    open.triangles.resize(open.triangles.size() - 3);  // a hole
    EXPECT_THROW(BoneProxy(0, 1.0, open, "open"), InvalidInput);
    ProxyShape flipped = ok;  // inward: accepted, turned outward
    for (size_t t = 0; t < flipped.triangles.size(); t += 3)
        std::swap(flipped.triangles[t + 1], flipped.triangles[t + 2]);
    EXPECT_NO_THROW(BoneProxy(0, 1.0, flipped, "flipped"));
    // A U-shaped solid (not star-shaped about its centroid): two boxes joined by a bar.
    ProxyShape u;
    const auto box = [&](dvec3 lo, dvec3 hi) {
        const int base = static_cast<int>(u.positions.size() / 3);
        for (int i = 0; i < 8; ++i) {
            const dvec3 p((i & 1) ? hi.x : lo.x, (i & 2) ? hi.y : lo.y, (i & 4) ? hi.z : lo.z);
            u.positions.insert(u.positions.end(), {float(p.x), float(p.y), float(p.z)});
        }
        const int f[12][3] = {{0, 2, 1}, {1, 2, 3}, {4, 5, 6}, {5, 7, 6}, {0, 1, 4}, {1, 5, 4},
                              {2, 6, 3}, {3, 6, 7}, {0, 4, 2}, {2, 4, 6}, {1, 3, 5}, {3, 7, 5}};
        for (const auto& tri : f) u.triangles.insert(u.triangles.end(), {base + tri[0], base + tri[1], base + tri[2]});
    };
    box(dvec3(0, 0, 0), dvec3(1, 0.1, 0.1));
    EXPECT_NO_THROW(BoneProxy(0, 1.0, u, "box"));
    box(dvec3(0, 0.5, 0), dvec3(1, 0.6, 0.1));  // a second, separate box: the centroid is outside both
    EXPECT_THROW(BoneProxy(0, 1.0, u, "two boxes"), InvalidInput);
}

TEST(Anatomy, MuscleActivationGrowsSmoothlyWithFlexion) {
    EXPECT_EQ(MuscleBulge::activation(-0.3, 1.5), 0.0);
    EXPECT_EQ(MuscleBulge::activation(0.0, 1.5), 0.0);
    EXPECT_NEAR(MuscleBulge::activation(0.75, 1.5), 0.5, 1e-12);
    EXPECT_EQ(MuscleBulge::activation(1.5, 1.5), 1.0);
    EXPECT_EQ(MuscleBulge::activation(2.5, 1.5), 1.0);
    double last = 0.0;
    for (int i = 1; i <= 30; ++i) {
        const double a = MuscleBulge::activation(0.05 * i, 1.5);
        EXPECT_GE(a, last);
        last = a;
    }
}

// ---- real characters ----------------------------------------------------------------------

std::string data_file(const std::string& name) { return std::string(SWEEPDEFORM_SHARED_DATA_DIR) + "/humans/" + name; }

struct Human {
    io::Character c;
    fit::FitResult fit;
    Binding binding;
    std::vector<int> elbows, knees;                            // lower links (left first)
    std::vector<std::pair<int, int>> elbow_links, knee_links;  // (upper, lower)
    dvec3 forward{0, -1, 0};
};

/// Loads and fits a character; the arms' and legs' chains give the elbows and knees.
Human load_human(const std::string& file, bool weld) {
    Human h;
    io::GltfLoadOptions o;
    o.weld = weld;
    h.c = io::load_gltf_character(data_file(file), o);
    const int B = static_cast<int>(h.c.bone_names.size());
    const Skeleton sk = Skeleton::from_arrays(B, h.c.bone_parents.data(), h.c.bone_rest.data(), h.c.bone_heads.data(),
                                              h.c.bone_tails.data());
    fit::FitInput in;
    in.vertex_count = static_cast<int>(h.c.positions.size() / 3);
    in.positions = h.c.positions.data();
    in.triangle_count = static_cast<int>(h.c.triangles.size() / 3);
    in.triangles = h.c.triangles.data();
    in.skeleton = sk;
    in.bone_names = h.c.bone_names;
    in.skin_slots = 4;
    in.skin_bones = h.c.skin_joints.data();
    in.skin_weights = h.c.skin_weights.data();
    h.fit = fit::fit_rig(in);
    const fit::RegionWeights& w = h.fit.weights;
    h.binding = bind_vertices(h.fit.rig, in.vertex_count, h.c.positions.data(), w.sweep_slots, w.sweep_ids.data(),
                              w.sweep_weights.data(), w.bone_slots, w.bone_ids.data(), w.bone_weights.data());
    h.forward = h.fit.chains.frame.forward;
    for (int side : {1, -1})
        for (const fit::Chain& ch : h.fit.chains.chains) {
            if (ch.side != side || ch.bones.size() < 2) continue;
            const int lower = ch.bones.back(), upper = ch.bones[ch.bones.size() - 2];
            if (ch.kind == fit::ChainKind::Arm) {
                h.elbows.push_back(lower);
                h.elbow_links.push_back({upper, lower});
            } else if (ch.kind == fit::ChainKind::Leg) {
                h.knees.push_back(lower);
                h.knee_links.push_back({upper, lower});
            }
        }
    return h;
}

/// Elbows and knees with all effects, and shoulders, hips and neck for folding.
void add_human_joints(Anatomy& a, const Human& h) {
    const dvec3 front = h.forward, back = -h.forward;
    for (int e : h.elbows) a.add_joint(e, JointKind::Elbow, &front);
    for (int k : h.knees) a.add_joint(k, JointKind::Knee, &back);
    for (const fit::Chain& ch : h.fit.chains.chains) {
        if (h.fit.chain_sweep[&ch - h.fit.chains.chains.data()] < 0) continue;
        const int first = ch.bones[std::min<size_t>(ch.first_swept, ch.bones.size() - 1)];
        if (ch.kind == fit::ChainKind::Arm || ch.kind == fit::ChainKind::Leg || ch.kind == fit::ChainKind::Neck) {
            try {
                a.add_joint(first, JointKind::Generic, nullptr);
            } catch (const InvalidInput&) {  // that chain's first key is no joint key
            }
        }
    }
}

struct BendCase {
    const char* file;
    bool weld;
};

class AnatomyCharacter : public ::testing::TestWithParam<BendCase> {};

TEST_P(AnatomyCharacter, FoldsVolumeAndProtrusionAtElbowAndKneeFlexion) {
    const std::string path = data_file(GetParam().file);
    if (!std::filesystem::exists(path)) GTEST_SKIP() << "../shared/data not found (" << path << "): skipped";
    const Human h = load_human(GetParam().file, GetParam().weld);
    ASSERT_FALSE(h.elbows.empty());
    ASSERT_FALSE(h.knees.empty());
    const Rig& rig = h.fit.rig;
    const int V = static_cast<int>(h.c.positions.size() / 3), T = static_cast<int>(h.c.triangles.size() / 3);
    Anatomy anatomy(rig, h.binding, h.c.triangles.data(), T);
    add_human_joints(anatomy, h);
    const MeshTopology& mesh = anatomy.mesh();
    std::printf("%s: %d vertices, %d triangles, %d joints\n", GetParam().file, V, T, anatomy.joint_count());

    // The rest pose is left as the sweeps make it.
    {
        Deformer d(rig, h.binding);
        std::vector<float> plain(3 * V), out(3 * V);
        const auto rest = io::rest_pose(h.c);
        d.deform(rest.data(), plain.data());
        anatomy.deform(d, rest.data(), out.data());
        const double worst = largest_move(out, plain);
        std::printf("  rest pose: effects move the skin by at most %.2e (pairs %d)\n", worst,
                    anatomy.stats().pairs_before);
        EXPECT_LE(worst, 1e-5);
    }

    struct Case {
        bool knee;
        double degrees;
    };
    for (const Case cs : {Case{false, 90}, Case{false, 120}, Case{false, 150}, Case{true, 90}, Case{true, 135}}) {
        const auto [upper, lower] = cs.knee ? h.knee_links[0] : h.elbow_links[0];
        const dvec3 towards = cs.knee ? -h.forward : h.forward;
        const auto pose = flex_pose(rig.skeleton, upper, lower, towards, glm::radians(cs.degrees));
        int joint = -1;
        for (int j = 0; j < anatomy.joint_count(); ++j)
            if (anatomy.joint(j).lower_bone == lower) joint = j;
        ASSERT_GE(joint, 0);
        std::vector<int32_t> region = anatomy.region_triangles(joint);
        std::sort(region.begin(), region.end());

        // Plain sweeps and linear blend skinning, intersections in the joint's region (brute force).
        Deformer plain_d(rig, h.binding);
        std::vector<float> plain(3 * V), lbs(3 * V), out(3 * V);
        plain_d.deform(pose.data(), plain.data());
        character_fit::skin_linearly(h.c, rig.skeleton, pose.data(), lbs.data());
        std::vector<TrianglePair> pairs;
        brute_force_pairs(mesh, region, plain.data(), pairs);
        const size_t sweep_pairs = pairs.size();
        brute_force_pairs(mesh, region, lbs.data(), pairs);
        const size_t lbs_pairs = pairs.size();

        // With the effects, the pose held for 12 frames (the volume feedback settles).
        Deformer d(rig, h.binding);
        for (int frame = 0; frame < 12; ++frame) anatomy.deform(d, pose.data(), out.data());
        const AnatomyStats st = anatomy.stats();
        brute_force_pairs(mesh, region, out.data(), pairs);
        const size_t after = pairs.size();
        std::vector<TrianglePair> everywhere;
        anatomy.count_intersections(out.data(), &everywhere);

        // The limb's volume: its sweep's skin closed by caps; and only its two links.
        const int sweep = anatomy.joint(joint).sweep;
        const double vs0 = anatomy.sweep_skin_rest_volume(sweep);
        const double vs_plain = anatomy.sweep_skin_volume(sweep, plain.data()) / vs0 - 1.0;
        const double vs = anatomy.sweep_skin_volume(sweep, out.data()) / vs0 - 1.0;
        std::vector<int32_t> links;
        for (int t = 0; t < T; ++t) {
            bool in = true;
            for (int k = 0; k < 3; ++k) {
                const int part = anatomy.parts().part[h.c.triangles[3 * t + k]];
                in = in && (part == upper || part == lower);
            }
            if (in) links.push_back(t);
        }
        const ClosedRegion two_links(mesh, links);
        const double vl0 = two_links.volume(h.c.positions.data());
        const double vl = two_links.volume(out.data()) / vl0 - 1.0,
                     vl_plain = two_links.volume(plain.data()) / vl0 - 1.0;

        std::printf(
            "  %s %3.0f deg: pairs in the joint region: linear blend %3zu, sweeps %3zu, with effects %zu "
            "(%d found this frame, %d passes; %zu in all regions) | limb volume vs rest: sweeps %+.2f %%, "
            "with effects %+.2f %% (upper+lower link only: %+.2f %% / %+.2f %%) | bulge %.1f mm, "
            "protrusion %.1f mm, deepest fold %.1f mm | %.2f ms\n",
            cs.knee ? "knee " : "elbow", cs.degrees, lbs_pairs, sweep_pairs, after, st.pairs_before,
            st.folding_iterations, everywhere.size(), 100 * vs_plain, 100 * vs, 100 * vl_plain, 100 * vl,
            1e3 * st.max_bulge, 1e3 * st.max_protrusion, 1e3 * st.max_fold_depth, st.ms_total);
        EXPECT_EQ(after, 0u) << (cs.knee ? "knee " : "elbow ") << cs.degrees;
        EXPECT_EQ(everywhere.size(), 0u);
        EXPECT_LT(std::abs(vs), 0.01) << (cs.knee ? "knee " : "elbow ") << cs.degrees;
        if (cs.degrees >= 120) EXPECT_GT(lbs_pairs, 0u) << "linear blend skinning should intersect here";

        if (!cs.knee && cs.degrees == 150) {
            // Protrusion: how far the olecranon pushes the skin out of the surface it meets
            // (the sweeps with bulge and volume restoration), and the difference to the same
            // frames with the protrusion switched off.
            const double push = st.max_protrusion;
            JointSettings s = anatomy.joint(joint).settings;
            s.protrusion = false;
            anatomy.set_joint_settings(joint, s);
            Deformer d2(rig, h.binding);
            std::vector<float> off(3 * V);
            for (int frame = 0; frame < 12; ++frame) anatomy.deform(d2, pose.data(), off.data());
            s.protrusion = true;
            anatomy.set_joint_settings(joint, s);
            const Joint& J = anatomy.joint(joint);
            const dvec3 e = -J.flexion_dir;  // extensor side, rest
            double stand_out = 0.0;
            for (int v = 0; v < V; ++v) {
                const dvec3 rest = at(h.c.positions, v);
                if (glm::length(rest - J.center) > 2.0 * std::max(J.key_ellipse.a, J.key_ellipse.b) ||
                    glm::dot(rest - J.center, e) < 0.0)
                    continue;
                stand_out = std::max(stand_out, glm::length(at(out, v) - at(off, v)));
            }
            const double radius = J.ellipse_radius(e);
            std::printf(
                "  elbow 150 deg: the olecranon pushes the skin %.1f mm out (%.0f %% of the elbow's %.1f mm "
                "radius there); %.1f mm against the same frames without it\n",
                1e3 * push, 100 * push / radius, 1e3 * radius, 1e3 * stand_out);
            // Plausible: a visible point (more than 2 % of the radius), no bone more than 60 % out.
            EXPECT_GT(push, 0.02 * radius);
            EXPECT_LT(push, 0.6 * radius);
            EXPECT_GT(stand_out, 0.0);
        }
    }
}

/// Area of the loop around `axis_point` in the plane through it with normal `normal`.
double section_area(const fit::FitMesh& mesh, const dvec3& axis_point, const dvec3& normal) {
    const std::vector<fit::SectionLoop> loops = fit::cut_mesh(mesh, axis_point, normal);
    const fit::PlaneFrame frame(axis_point, normal, dvec3(0, 0, 1));
    std::vector<std::vector<dvec2>> polygons;
    for (const fit::SectionLoop& l : loops) {
        polygons.emplace_back();
        for (const fit::SectionPoint& p : l.points) polygons.back().push_back(frame.to_plane(p.p));
    }
    const fit::LoopPick pick = fit::pick_loop(polygons, dvec2(0.0), 0.0);
    return pick.loop >= 0 && pick.contains ? std::abs(fit::polygon_area(polygons[pick.loop])) : 0.0;
}

TEST_P(AnatomyCharacter, PlainSweepsKeepTheSectionsBelowTheElbowAndKnee) {
    // Plain sweeps (no effects), the instrument's collapse measure: the cross-section
    // perpendicular to the posed forearm or shin a fifth of its length below the joint, against
    // rest. With two keys a link the joint's turn was spread over a third of the shin and the
    // calf's back there folded into the thigh (MakeHuman at 135 degrees: 0.81 of rest; linear
    // blend skinning 1.00); with a key more below each elbow and knee it stays above 0.9.
    const std::string path = data_file(GetParam().file);
    if (!std::filesystem::exists(path)) GTEST_SKIP() << "../shared/data not found (" << path << "): skipped";
    const Human h = load_human(GetParam().file, GetParam().weld);
    const Rig& rig = h.fit.rig;
    const Skeleton& sk = rig.skeleton;
    const int V = static_cast<int>(h.c.positions.size() / 3), T = static_cast<int>(h.c.triangles.size() / 3);
    const fit::FitMesh rest_mesh(V, h.c.positions.data(), T, h.c.triangles.data());
    const double minimum = std::string(GetParam().file).rfind("mh_", 0) == 0 ? 0.9 : 0.8;
    for (const bool knee : {false, true})
        for (const double degrees : knee ? std::vector<double>{90, 135} : std::vector<double>{120, 150}) {
            const auto [upper, lower] = knee ? h.knee_links[0] : h.elbow_links[0];
            const auto pose = flex_pose(sk, upper, lower, knee ? -h.forward : h.forward, glm::radians(degrees));
            Deformer d(rig, h.binding);
            std::vector<float> out(3 * V);
            d.deform(pose.data(), out.data());
            const fit::FitMesh posed(V, out.data(), T, h.c.triangles.data());
            SkeletonPose sp;
            sp.set(sk, pose.data());
            const dvec3 head0 = sk.heads[lower], tail0 = sk.tails[lower];
            const dvec3 head1(sp.deform[lower] * dvec4(head0, 1.0)), tail1(sp.deform[lower] * dvec4(tail0, 1.0));
            const double a0 = section_area(rest_mesh, head0 + 0.2 * (tail0 - head0), glm::normalize(tail0 - head0));
            const double a1 = section_area(posed, head1 + 0.2 * (tail1 - head1), glm::normalize(tail1 - head1));
            ASSERT_GT(a0, 0.0);
            std::printf("  %s %3.0f deg: section a fifth below the joint %.3f of rest\n", knee ? "knee " : "elbow",
                        degrees, a1 / a0);
            // Folded far, the plane also cuts the upper link (twice the area): not this measure.
            if (a1 / a0 > 1.5) continue;
            // CesiumMan's coarse elbow keeps less (Preserve Volume: 0.83 at 120 degrees; with two
            // keys a link the sweeps kept 0.75 at 150).
            EXPECT_GE(a1 / a0, minimum) << (knee ? "knee " : "elbow ") << degrees;
        }
}

INSTANTIATE_TEST_SUITE_P(Humans, AnatomyCharacter,
                         ::testing::Values(BendCase{"mh_male_game_engine.glb", false}, BendCase{"CesiumMan.glb", true}),
                         [](const ::testing::TestParamInfo<BendCase>& info) {
                             return std::string(info.param.weld ? "CesiumMan" : "MakeHuman");
                         });

// ---- the C ABI ------------------------------------------------------------------------------

/// The synthetic arm through the public header.
struct AbiArm {
    test::Arm arm;
    std::vector<int32_t> tris = arm.ring_triangles();
    sd_rig* rig = nullptr;
    sd_binding* binding = nullptr;
    sd_deformer* deformer = nullptr;

    AbiArm() {
        const Skeleton& sk = arm.rig.skeleton;
        std::vector<float> rest, heads, tails;
        for (int b = 0; b < sk.bone_count(); ++b) {
            for (int c = 0; c < 4; ++c)
                for (int r = 0; r < 4; ++r) rest.push_back(static_cast<float>(sk.rest[b][c][r]));
            for (int k = 0; k < 3; ++k) {
                heads.push_back(static_cast<float>(sk.heads[b][k]));
                tails.push_back(static_cast<float>(sk.tails[b][k]));
            }
        }
        EXPECT_EQ(sd_rig_create(sk.bone_count(), sk.parents.data(), rest.data(), heads.data(), tails.data(), &rig),
                  SD_OK);
        std::vector<float> centers, orientations, half_axes, fractions;
        std::vector<int32_t> bones, parents;
        for (const KeyEllipse& k : arm.rig.sweeps[0].keys) {
            centers.insert(centers.end(), {float(k.center.x), float(k.center.y), float(k.center.z)});
            orientations.insert(orientations.end(), {float(k.orientation.w), float(k.orientation.x),
                                                     float(k.orientation.y), float(k.orientation.z)});
            half_axes.insert(half_axes.end(), {float(k.a), float(k.b)});
            fractions.insert(fractions.end(), {float(k.swing_fraction), float(k.twist_fraction)});
            bones.push_back(k.bone);
            parents.push_back(k.joint_parent);
        }
        EXPECT_EQ(sd_rig_add_sweep(rig, static_cast<int32_t>(bones.size()), centers.data(), orientations.data(),
                                   half_axes.data(), bones.data(), parents.data(), fractions.data(), nullptr),
                  SD_OK)
            << sd_last_error();
        const int V = arm.vertex_count();
        std::vector<int32_t> ids(V, 0);
        std::vector<float> w(V, 1.0f);
        EXPECT_EQ(sd_bind(rig, V, arm.mesh.data(), 1, ids.data(), w.data(), 0, nullptr, nullptr, &binding), SD_OK);
        EXPECT_EQ(sd_deformer_create(rig, binding, &deformer), SD_OK);
    }
    ~AbiArm() {
        sd_deformer_destroy(deformer);
        sd_binding_destroy(binding);
        sd_rig_destroy(rig);
    }
    int32_t triangle_count() const { return static_cast<int32_t>(tris.size() / 3); }
};

void expect_status(sd_status got, sd_status want, const char* what) {
    EXPECT_EQ(got, want) << what << ": " << sd_last_error();
    if (want != SD_OK) EXPECT_GT(std::strlen(sd_last_error()), 0u) << what;
}

TEST(AnatomyAbi, InvalidInputIsRefusedWithAMessage) {
    AbiArm a;
    const float kNaN = std::numeric_limits<float>::quiet_NaN();
    sd_anatomy* an = nullptr;
    expect_status(sd_anatomy_create(nullptr, a.binding, a.triangle_count(), a.tris.data(), &an),
                  SD_ERR_INVALID_ARGUMENT, "NULL rig");
    expect_status(sd_anatomy_create(a.rig, a.binding, 0, a.tris.data(), &an), SD_ERR_INVALID_ARGUMENT, "no triangles");
    expect_status(sd_anatomy_create(a.rig, a.binding, a.triangle_count(), nullptr, &an), SD_ERR_INVALID_ARGUMENT,
                  "NULL triangles");
    std::vector<int32_t> bad = a.tris;
    bad[5] = a.arm.vertex_count();
    expect_status(sd_anatomy_create(a.rig, a.binding, a.triangle_count(), bad.data(), &an), SD_ERR_INVALID_ARGUMENT,
                  "index out of range");
    bad[5] = -1;
    expect_status(sd_anatomy_create(a.rig, a.binding, a.triangle_count(), bad.data(), &an), SD_ERR_INVALID_ARGUMENT,
                  "negative index");
    EXPECT_EQ(an, nullptr);
    {  // a binding made for another rig
        AbiArm other;
        sd_rig* thick = nullptr;
        ASSERT_EQ(sd_rig_clone(other.rig, &thick), SD_OK);
        std::vector<float> c = {0, 0, 0, 1, 0, 0}, q = {0.5f, 0.5f, 0.5f, 0.5f, 0.5f, 0.5f, 0.5f, 0.5f},
                           ab = {0.2f, 0.2f, 0.2f, 0.2f}, fr = {0.5f, 0.5f, 0.5f, 0.5f};
        std::vector<int32_t> bones = {0, 0}, par = {-1, -1};
        ASSERT_EQ(
            sd_rig_add_sweep(thick, 2, c.data(), q.data(), ab.data(), bones.data(), par.data(), fr.data(), nullptr),
            SD_OK);
        expect_status(sd_anatomy_create(thick, a.binding, a.triangle_count(), a.tris.data(), &an), SD_ERR_MISMATCH,
                      "other rig");
        sd_rig_destroy(thick);
    }
    ASSERT_EQ(sd_anatomy_create(a.rig, a.binding, a.triangle_count(), a.tris.data(), &an), SD_OK) << sd_last_error();

    const float front[3] = {0, 1, 0}, nan3[3] = {kNaN, 0, 0}, along[3] = {1, 0, 0};
    int32_t joint = -1;
    expect_status(sd_anatomy_add_joint(an, 1, 7, front, &joint), SD_ERR_INVALID_ARGUMENT, "bad kind");
    expect_status(sd_anatomy_add_joint(an, 9, SD_JOINT_KIND_ELBOW, front, &joint), SD_ERR_INVALID_ARGUMENT,
                  "bone out of range");
    expect_status(sd_anatomy_add_joint(an, 0, SD_JOINT_KIND_ELBOW, front, &joint), SD_ERR_INVALID_ARGUMENT,
                  "no joint key on bone 0");
    expect_status(sd_anatomy_add_joint(an, 1, SD_JOINT_KIND_ELBOW, nullptr, &joint), SD_ERR_INVALID_ARGUMENT,
                  "elbow without direction");
    expect_status(sd_anatomy_add_joint(an, 1, SD_JOINT_KIND_ELBOW, nan3, &joint), SD_ERR_INVALID_ARGUMENT,
                  "NaN direction");
    expect_status(sd_anatomy_add_joint(an, 1, SD_JOINT_KIND_ELBOW, along, &joint), SD_ERR_INVALID_ARGUMENT,
                  "direction along the link");
    EXPECT_EQ(sd_anatomy_joint_count(an), 0);
    expect_status(sd_anatomy_add_joint(an, 1, SD_JOINT_KIND_ELBOW, front, &joint), SD_OK, "elbow");
    EXPECT_EQ(joint, 0);
    expect_status(sd_anatomy_add_joint(an, 1, SD_JOINT_KIND_GENERIC, nullptr, nullptr), SD_ERR_INVALID_ARGUMENT,
                  "twice");
    EXPECT_EQ(sd_anatomy_joint_count(an), 1);
    EXPECT_EQ(sd_anatomy_joint_count(nullptr), -1);

    int32_t effects = 0;
    expect_status(sd_anatomy_get_joint_effects(an, 0, &effects), SD_OK, "effects");
    EXPECT_EQ(effects, SD_EFFECT_FOLDING | SD_EFFECT_PROTRUSION | SD_EFFECT_BULGE);
    expect_status(sd_anatomy_set_joint_effects(an, 0, 8), SD_ERR_INVALID_ARGUMENT, "bad effects");
    expect_status(sd_anatomy_set_joint_effects(an, 1, 1), SD_ERR_INVALID_ARGUMENT, "bad joint");
    expect_status(sd_anatomy_set_joint_parameter(an, 0, SD_JOINT_PARAM_BULGE_STRENGTH, 2.0f), SD_ERR_INVALID_ARGUMENT,
                  "strength > 1");
    expect_status(sd_anatomy_set_joint_parameter(an, 0, SD_JOINT_PARAM_BULGE_FALLOFF, 0.0f), SD_ERR_INVALID_ARGUMENT,
                  "falloff 0");
    expect_status(sd_anatomy_set_joint_parameter(an, 0, SD_JOINT_PARAM_PROTRUSION_STRENGTH, kNaN),
                  SD_ERR_INVALID_ARGUMENT, "NaN");
    expect_status(sd_anatomy_set_joint_parameter(an, 0, 99, 1.0f), SD_ERR_INVALID_ARGUMENT, "unknown parameter");
    expect_status(sd_anatomy_set_joint_parameter(an, 0, SD_JOINT_PARAM_BULGE_STRENGTH, 0.25f), SD_OK, "strength");
    float value = 0.0f;
    expect_status(sd_anatomy_get_joint_parameter(an, 0, SD_JOINT_PARAM_BULGE_STRENGTH, &value), SD_OK, "get");
    EXPECT_EQ(value, 0.25f);
    expect_status(sd_anatomy_set_volume_feedback(an, 3, 1), SD_ERR_INVALID_ARGUMENT, "feedback mode");
    expect_status(sd_anatomy_set_folding_iterations(an, 0), SD_ERR_INVALID_ARGUMENT, "iterations");

    // A user proxy: an octahedron is fine, an open one is not.
    const float octa[] = {0.2f, 0,      -0.05f, 1.2f, 0, -0.05f, 1, 0.03f, -0.05f,
                          1,    -0.03f, -0.05f, 1,    0, -0.02f, 1, 0,     -0.09f};
    const int32_t faces[] = {0, 2, 4, 2, 1, 4, 1, 3, 4, 3, 0, 4, 2, 0, 5, 1, 2, 5, 3, 1, 5, 0, 3, 5};
    expect_status(sd_anatomy_set_joint_proxy(an, 0, 6, octa, 7, faces, 1.0f), SD_ERR_INVALID_ARGUMENT, "open proxy");
    expect_status(sd_anatomy_set_joint_proxy(an, 0, 6, octa, 8, faces, 1.5f), SD_ERR_INVALID_ARGUMENT, "fraction");

    // Frames: wrong counts, a NaN pose, a deformer of another rig.
    const auto pose = a.arm.pose(glm::radians(150.0));
    std::vector<float> out(a.arm.mesh.size());
    const int32_t V = a.arm.vertex_count();
    expect_status(sd_deform_with_anatomy(a.deformer, an, 2, pose.data(), V, out.data()), SD_ERR_MISMATCH, "bone count");
    expect_status(sd_deform_with_anatomy(a.deformer, an, 3, pose.data(), V + 1, out.data()), SD_ERR_MISMATCH,
                  "vertex count");
    std::vector<float> nan_pose = pose;
    nan_pose[5] = kNaN;
    expect_status(sd_deform_with_anatomy(a.deformer, an, 3, nan_pose.data(), V, out.data()), SD_ERR_INVALID_ARGUMENT,
                  "NaN pose");
    expect_status(sd_deform_with_anatomy(nullptr, an, 3, pose.data(), V, out.data()), SD_ERR_INVALID_ARGUMENT,
                  "NULL deformer");
    {
        AbiArm same;  // another deformer of an identical rig is fine
        expect_status(sd_deform_with_anatomy(same.deformer, an, 3, pose.data(), V, out.data()), SD_OK, "same rig");
        sd_rig* thick = nullptr;  // one of a different rig is not
        ASSERT_EQ(sd_rig_clone(same.rig, &thick), SD_OK);
        std::vector<float> c = {0, 0, 0, 1, 0, 0}, q = {0.5f, 0.5f, 0.5f, 0.5f, 0.5f, 0.5f, 0.5f, 0.5f},
                           ab = {0.2f, 0.2f, 0.2f, 0.2f}, fr = {0.5f, 0.5f, 0.5f, 0.5f};
        std::vector<int32_t> bones = {0, 0}, par = {-1, -1};
        ASSERT_EQ(
            sd_rig_add_sweep(thick, 2, c.data(), q.data(), ab.data(), bones.data(), par.data(), fr.data(), nullptr),
            SD_OK);
        sd_binding* b2 = nullptr;
        sd_deformer* d2 = nullptr;
        std::vector<int32_t> ids(2 * V, -1);
        std::vector<float> w(2 * V, 0.0f);
        for (int v = 0; v < V; ++v) {
            ids[2 * v] = 0;
            w[2 * v] = 1.0f;
        }
        ASSERT_EQ(sd_bind(thick, V, a.arm.mesh.data(), 2, ids.data(), w.data(), 0, nullptr, nullptr, &b2), SD_OK)
            << sd_last_error();
        ASSERT_EQ(sd_deformer_create(thick, b2, &d2), SD_OK);
        expect_status(sd_deform_with_anatomy(d2, an, 3, pose.data(), V, out.data()), SD_ERR_MISMATCH, "another rig");
        sd_deformer_destroy(d2);
        sd_binding_destroy(b2);
        sd_rig_destroy(thick);
    }
    std::vector<float> nan_positions(out.size(), 0.0f);
    nan_positions[7] = kNaN;
    expect_status(sd_anatomy_apply(an, nullptr, 3, pose.data(), V, nan_positions.data()), SD_ERR_INVALID_ARGUMENT,
                  "NaN positions");
    double stats[SD_STAT_COUNT];
    expect_status(sd_anatomy_get_stats(an, SD_STAT_COUNT + 1, stats), SD_ERR_INVALID_ARGUMENT, "too many stats");
    expect_status(sd_anatomy_get_volume_offsets(an, 2, stats), SD_ERR_MISMATCH, "sweep count");
    int32_t pairs = -1;
    expect_status(sd_anatomy_count_intersections(an, V - 1, out.data(), &pairs), SD_ERR_MISMATCH,
                  "count: vertex count");
    sd_anatomy_destroy(an);
    sd_anatomy_destroy(nullptr);
}

TEST(AnatomyAbi, BentArmThroughTheAbi) {
    AbiArm a;
    sd_anatomy* an = nullptr;
    ASSERT_EQ(sd_anatomy_create(a.rig, a.binding, a.triangle_count(), a.tris.data(), &an), SD_OK) << sd_last_error();
    const float front[3] = {0, 1, 0};
    ASSERT_EQ(sd_anatomy_add_joint(an, 1, SD_JOINT_KIND_ELBOW, front, nullptr), SD_OK) << sd_last_error();
    const auto pose = a.arm.pose(glm::radians(150.0));
    const int32_t V = a.arm.vertex_count();
    std::vector<float> plain(a.arm.mesh.size()), out(a.arm.mesh.size());
    ASSERT_EQ(sd_deform(a.deformer, 3, pose.data(), V, plain.data()), SD_OK);
    int32_t before = 0, after = -1;
    ASSERT_EQ(sd_anatomy_count_intersections(an, V, plain.data(), &before), SD_OK);
    // Two ways to the same frame: the combined call, and sd_deform then sd_anatomy_apply.
    for (int frame = 0; frame < 6; ++frame)
        ASSERT_EQ(sd_deform_with_anatomy(a.deformer, an, 3, pose.data(), V, out.data()), SD_OK);
    ASSERT_EQ(sd_anatomy_count_intersections(an, V, out.data(), &after), SD_OK);
    double stats[SD_STAT_COUNT];
    ASSERT_EQ(sd_anatomy_get_stats(an, SD_STAT_COUNT, stats), SD_OK);
    std::vector<double> offsets(1);
    ASSERT_EQ(sd_anatomy_get_volume_offsets(an, 1, offsets.data()), SD_OK);
    std::printf(
        "ABI, arm at 150 deg: %d pairs before, %d after; stats: pairs %g -> %g in %g passes, I_C %.3g, total %.3f ms\n",
        before, after, stats[SD_STAT_PAIRS_BEFORE], stats[SD_STAT_PAIRS_AFTER], stats[SD_STAT_FOLDING_ITERATIONS],
        offsets[0], stats[SD_STAT_MS_TOTAL]);
    EXPECT_GT(before, 0);
    EXPECT_EQ(after, 0);
    EXPECT_EQ(stats[SD_STAT_PAIRS_AFTER], 0.0);
    // Without feedback and restoration (no state carried between frames) the combined call
    // equals sd_deform + sd_anatomy_apply.
    ASSERT_EQ(sd_anatomy_set_volume_feedback(an, 0, 0), SD_OK);
    ASSERT_EQ(sd_deform_with_anatomy(a.deformer, an, 3, pose.data(), V, out.data()), SD_OK);
    std::vector<float> two(a.arm.mesh.size());
    ASSERT_EQ(sd_deform(a.deformer, 3, pose.data(), V, two.data()), SD_OK);
    ASSERT_EQ(sd_anatomy_apply(an, a.deformer, 3, pose.data(), V, two.data()), SD_OK) << sd_last_error();
    EXPECT_EQ(two, out);
    // Switches: with every effect off the result is the plain deformation.
    ASSERT_EQ(sd_anatomy_set_joint_effects(an, 0, 0), SD_OK);
    ASSERT_EQ(sd_anatomy_set_volume_feedback(an, 0, 0), SD_OK);
    ASSERT_EQ(sd_deform_with_anatomy(a.deformer, an, 3, pose.data(), V, out.data()), SD_OK);
    EXPECT_EQ(out, plain);
    sd_anatomy_destroy(an);
}

}  // namespace
}  // namespace sd::anatomy
