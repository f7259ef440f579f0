// Normal-cone culling's outline condition (Volino and Magnenat-Thalmann 1994), analytic
// cases: which BVH nodes are disks, when a projected outline crosses itself, and the query
// with culling against brute force on a ramp whose normals all point up but whose last turn
// passes through its first (the cone alone culls it whole and finds nothing).
#include "geometry/bvh.h"
#include "geometry/mesh_topology.h"
#include "geometry/patch_outline.h"
#include "geometry/self_intersection.h"
#include "measure/measure.h"

#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <vector>

namespace sd::anatomy {
namespace {

struct Sheet {
    std::vector<float> positions;
    std::vector<int32_t> triangles;
    MeshTopology mesh;
    std::vector<int32_t> all;
};

/// A grid of (columns+1) x (rows+1) vertices placed by `at(i, j)`, each cell two triangles
/// (counter-clockwise seen from +z where `at` keeps i along x and j along y); cells for
/// which `hole(i, j)` holds are left out.
template <class At, class Hole>
Sheet grid(int columns, int rows, At at, Hole hole) {
    Sheet s;
    for (int j = 0; j <= rows; ++j)
        for (int i = 0; i <= columns; ++i) {
            const std::array<double, 3> p = at(i, j);
            for (double x : p) s.positions.push_back(static_cast<float>(x));
        }
    auto id = [&](int i, int j) { return j * (columns + 1) + i; };
    for (int j = 0; j < rows; ++j)
        for (int i = 0; i < columns; ++i) {
            if (hole(i, j)) continue;
            s.triangles.insert(s.triangles.end(), {id(i, j), id(i + 1, j), id(i + 1, j + 1)});
            s.triangles.insert(s.triangles.end(), {id(i, j), id(i + 1, j + 1), id(i, j + 1)});
        }
    const int T = static_cast<int>(s.triangles.size() / 3);
    s.mesh = MeshTopology::build(static_cast<int>(s.positions.size() / 3), s.triangles.data(), T, s.positions.data());
    for (int t = 0; t < T; ++t) s.all.push_back(t);
    return s;
}

Sheet flat(int columns, int rows) {
    return grid(
        columns, rows,
        [&](int i, int j) {
            return std::array<double, 3>{0.01 * i, 0.01 * j, 0.0};
        },
        [](int, int) { return false; });
}

/// A strip wound 1.15 times about +z, its height rising and falling again, so that its last
/// part passes down through its first: every normal within a few degrees of +z.
Sheet ramp() {
    const int along = 240, across = 4;
    const double turns = 2.0 * M_PI * 1.15;
    return grid(
        along, across,
        [&](int i, int j) {
            const double a = turns * i / along;
            const double r = 1.0 + 0.02 * a + 0.1 * j;
            return std::array<double, 3>{r * std::cos(a), r * std::sin(a), 0.2 * std::sin(M_PI * a / turns)};
        },
        [](int, int) { return false; });
}

/// A sheet's BVH (with normal cones) and its nodes' outlines.
struct Tree {
    TriangleBvh bvh;
    PatchOutlines outlines;
    Tree(const Sheet& s, int leaf_size) {
        bvh.build(s.mesh, s.all, s.positions.data(), leaf_size, true);
        outlines.build(bvh);
    }
};

TEST(PatchOutline, AFlatGridIsADiskWhoseOutlineIsItsBorder) {
    const Sheet s = flat(12, 7);
    Tree tree(s, 8);
    const TriangleBvh& bvh = tree.bvh;
    const PatchOutlines& outlines = tree.outlines;
    ASSERT_TRUE(outlines.is_disk(0));
    EXPECT_EQ(outlines.outline(0).size(), 2u * (12 + 7));
    PatchOutlines::Scratch scratch;
    const float up[3] = {0, 0, 1};
    EXPECT_TRUE(outlines.projects_simply(0, up, s.positions.data(), scratch));
    // Every connected node of a flat grid is a disk or has a pinch (two cells meeting at a corner).
    int disks = 0;
    for (int n = 0; n < static_cast<int>(bvh.nodes().size()); ++n) disks += outlines.is_disk(n);
    EXPECT_GT(disks, static_cast<int>(bvh.nodes().size()) / 2);
}

TEST(PatchOutline, AGridWithAHoleIsNoDisk) {
    const Sheet s = grid(
        10, 10,
        [](int i, int j) {
            return std::array<double, 3>{0.01 * i, 0.01 * j, 0.0};
        },
        [](int i, int j) { return i >= 4 && i < 6 && j >= 4 && j < 6; });
    Tree tree(s, 8);
    const TriangleBvh& bvh = tree.bvh;
    const PatchOutlines& outlines = tree.outlines;
    EXPECT_TRUE(bvh.connected(0));
    EXPECT_FALSE(outlines.is_disk(0));  // an annulus: V - E + F = 0
}

TEST(PatchOutline, TheRampsOutlineCrossesItselfSeenAlongItsNormals) {
    const Sheet s = ramp();
    Tree tree(s, 8);
    const TriangleBvh& bvh = tree.bvh;
    const PatchOutlines& outlines = tree.outlines;
    const NormalCone& root = bvh.cone(0);
    EXPECT_GT(root.cos_half_angle, 0.9f);  // the cone alone would cull the whole ramp
    PatchOutlines::Scratch scratch;
    const float up[3] = {0, 0, 1};
    int overlapping = 0, simple = 0;
    for (int n = 0; n < static_cast<int>(bvh.nodes().size()); ++n) {
        if (!outlines.is_disk(n)) continue;
        if (outlines.projects_simply(n, up, s.positions.data(), scratch))
            ++simple;
        else
            ++overlapping;
    }
    EXPECT_GT(overlapping, 0);
    EXPECT_GT(simple, overlapping);
}

TEST(PatchOutline, TwoCellsMeetingAtACornerAreNoDisk) {
    // Two cells of a 2 x 2 grid on a diagonal: their shared vertex's triangles form two fans,
    // so no node holding a triangle at it is taken for a disk, however it is split.
    const Sheet s = grid(
        2, 2,
        [](int i, int j) {
            return std::array<double, 3>{0.01 * i, 0.01 * j, 0.0};
        },
        [](int i, int j) { return i != j; });
    for (int leaf : {1, 2, 4}) {
        Tree tree(s, leaf);
        const TriangleBvh& bvh = tree.bvh;
        const PatchOutlines& outlines = tree.outlines;
        for (int n = 0; n < static_cast<int>(bvh.nodes().size()); ++n) EXPECT_FALSE(outlines.is_disk(n)) << n;
    }
}

TEST(PatchOutline, TwoHalvesOfAFlatGridJoinIntoADiskSeenSimply) {
    const Sheet s = flat(16, 4);
    Tree tree(s, 8);
    const TriangleBvh& bvh = tree.bvh;
    const PatchOutlines& outlines = tree.outlines;
    const int l = bvh.node(0).first;
    ASSERT_TRUE(outlines.is_disk(l) && outlines.is_disk(l + 1));
    PatchOutlines::Scratch scratch;
    const float up[3] = {0, 0, 1};
    EXPECT_TRUE(outlines.union_projects_simply(l, l + 1, up, s.positions.data(), scratch));
    // Seen edge-on the outline folds onto itself.
    const float side[3] = {0, 1, 0};
    EXPECT_FALSE(outlines.union_projects_simply(l, l + 1, side, s.positions.data(), scratch));
}

TEST(NormalConeCulling, FindsTheBruteForcePairsOfARampPassingThroughItself) {
    const Sheet s = ramp();
    std::vector<TrianglePair> brute, culled, plain;
    brute_force_pairs(s.mesh, s.all, s.positions.data(), brute);
    for (bool parallel : {true, false}) {
        CpuCollisionBackend cpu({true, 8, parallel});
        cpu.set_triangles(s.mesh, s.all, s.positions.data());
        cpu.find_pairs(s.positions.data(), culled);
        EXPECT_EQ(culled, brute);
        CpuCollisionBackend small_leaves({true, 2, parallel});
        small_leaves.set_triangles(s.mesh, s.all, s.positions.data());
        small_leaves.find_pairs(s.positions.data(), culled);
        EXPECT_EQ(culled, brute);
    }
    CpuCollisionBackend no_cones({false, 8, true});
    no_cones.set_triangles(s.mesh, s.all, s.positions.data());
    no_cones.find_pairs(s.positions.data(), plain);
    EXPECT_EQ(plain, brute);
    EXPECT_GE(brute.size(), 8u);  // the strip's four cells across, crossed by the last turn
    // sd_measure_intersections' count (the demo's and the reports' figures).
    EXPECT_EQ(measure::intersecting_pairs(static_cast<int>(s.positions.size() / 3), s.positions.data(),
                                          static_cast<int>(s.triangles.size() / 3), s.triangles.data(), {}),
              static_cast<int64_t>(brute.size()));
    // What the cheaper culling without the outline's test (the folding's) gives up: the ramp
    // is one connected patch within the cone, culled whole.
    CpuCollisionBackend cone_only({true, 8, true, false});
    cone_only.set_triangles(s.mesh, s.all, s.positions.data());
    cone_only.find_pairs(s.positions.data(), culled);
    EXPECT_TRUE(culled.empty());
}

TEST(NormalConeCulling, StillSkipsAFlatSheetWhole) {
    const Sheet s = flat(40, 40);
    std::vector<TrianglePair> pairs;
    CpuCollisionBackend culled({true, 8, true});
    culled.set_triangles(s.mesh, s.all, s.positions.data());
    culled.find_pairs(s.positions.data(), pairs);
    EXPECT_TRUE(pairs.empty());
    EXPECT_EQ(culled.last_stats().triangle_tests, 0);
    CpuCollisionBackend plain({false, 8, true});
    plain.set_triangles(s.mesh, s.all, s.positions.data());
    plain.find_pairs(s.positions.data(), pairs);
    EXPECT_TRUE(pairs.empty());
    EXPECT_GT(plain.last_stats().triangle_tests, 1000);
}

}  // namespace
}  // namespace sd::anatomy
