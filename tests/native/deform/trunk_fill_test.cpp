// A bent trunk's volume given to its skin as a fill (deform/trunk_fill.h): the raise and the
// level on hand-made skins first, then a thick tube bent at its middle joint, filled against
// grown by its sections. The MakeHuman trunk bent 45 to 60 degrees: fit/trunk_bend_test.cpp.
#include "deform/trunk_fill.h"

#include "deform/deform.h"
#include "geometry/mesh_topology.h"
#include "geometry/mesh_volume.h"
#include "math/segment_distance.h"
#include "test_arm.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

namespace sd {
namespace {

TEST(TrunkFill, SkinIsRaisedToTheLevelButNotPastIt) {
    EXPECT_NEAR(fill_raise(1.0, 1.0, 1.05), 0.05, 1e-12);  // at its rest distance: up to the level
    EXPECT_NEAR(fill_raise(2.0, 2.04, 1.05), 0.06, 1e-12);
    EXPECT_EQ(fill_raise(1.0, 1.06, 1.05), 0.0);  // already further out: stays
    EXPECT_EQ(fill_raise(1.0, 1.0, 1.0), 0.0);    // level 1: nothing
    EXPECT_EQ(fill_raise(1.0, 1.0, 0.9), 0.0);
    EXPECT_EQ(fill_raise(0.0, 0.5, 1.2), 0.0);  // no rest distance: no direction
}

TEST(TrunkFill, SkinPressedTowardsTheSpineKeepsLessOfTheRaiseAndNoneInADeepFold) {
    // Pressed to 0.9 of its rest distance (kPressedIntoFold 0.25): raised by 0.6 of the level's
    // (L - 1) rest, not all the way to L rest; pressed to 0.75 or nearer: not at all.
    EXPECT_NEAR(fill_raise(1.0, 0.9, 1.05), 0.6 * 0.05, 1e-12);
    EXPECT_NEAR(fill_raise(1.0, 0.95, 1.1), 0.8 * 0.1, 1e-12);
    EXPECT_EQ(fill_raise(1.0, 0.75, 1.2), 0.0);
    EXPECT_EQ(fill_raise(1.0, 0.5, 1.2), 0.0);
}

TEST(TrunkFill, TheLevelPutsBackWhatIsAsked) {
    // Four vertices of unit area, weight and rest distance at 1.00, 1.02, 1.04 and 1.08 of it:
    // level 1.03 puts back 0.03 + 0.01.
    std::vector<FillVertex> skin;
    for (double r : {1.0, 1.02, 1.04, 1.08}) skin.push_back({1.0, r, 1.0, 1.0});
    EXPECT_NEAR(fill_level(skin, 0.04), 1.03, 1e-12);
    // A fifth, pressed to 0.875 (half the raise's share): 0.5 (L - 1) more at every level.
    skin.push_back({1.0, 0.875, 1.0, 1.0});
    EXPECT_NEAR(fill_level(skin, 0.04 + 0.5 * 0.03), 1.03, 1e-12);
    EXPECT_EQ(fill_level(skin, 0.0), 1.0);
    EXPECT_EQ(fill_level(skin, -1.0), 1.0);
    EXPECT_EQ(fill_level(skin, 1e6), kHighestFillLevel);  // more than the highest level gives
    EXPECT_EQ(fill_level({}, 1.0), kHighestFillLevel);
}

TEST(TrunkFill, TheLevelIsWhereTheSumOfRaisesReachesWhatIsAsked) {
    // Random skins: the level found on the pieces equals bisection of the sum itself.
    std::mt19937 rng(7);
    std::uniform_real_distribution<double> rest(0.05, 0.3), ratio(0.6, 1.4), unit(0.0, 1.0);
    for (int trial = 0; trial < 50; ++trial) {
        std::vector<FillVertex> skin(200);
        for (FillVertex& v : skin) v = {rest(rng), 0.0, unit(rng), unit(rng) * 1e-3};
        for (FillVertex& v : skin) v.posed = v.rest * ratio(rng);
        const auto put_back = [&](double level) {
            double sum = 0.0;
            for (const FillVertex& v : skin) sum += v.area * v.weight * fill_raise(v.rest, v.posed, level);
            return sum;
        };
        const double asked = put_back(1.0 + 0.3 * unit(rng));
        const double level = fill_level(skin, asked);
        EXPECT_NEAR(put_back(level), asked, 1e-12 + 1e-9 * asked) << "trial " << trial;
        EXPECT_LT(put_back(level - 1e-7), asked) << "trial " << trial << ": not the lowest level";
    }
}

/// A thick tube (half-axes 0.6 and 0.5 on links 1 long: a trunk, its keys following blends of
/// the bones) bent by `degrees` at its middle joint, deformed with and without its skin's
/// triangles (filled, or grown by its sections), and with no volume kept.
struct BentTube {
    test::Arm tube{0.6, 0.5};
    std::vector<int32_t> triangles = tube.ring_triangles();
    std::vector<float> rest = tube.mesh, filled, grown, kept_none;
    double level = 1.0;

    explicit BentTube(double degrees) {
        const std::vector<float> pose = tube.pose(glm::radians(degrees));
        filled = grown = kept_none = std::vector<float>(tube.mesh.size());
        Deformer fill(tube.rig, tube.bind()), grow(tube.rig, tube.bind()), none(tube.rig, tube.bind());
        fill.set_skin_triangles(triangles);
        none.set_volume_preservation(false, 0.0);
        fill.deform(pose.data(), filled.data());
        grow.deform(pose.data(), grown.data());
        none.deform(pose.data(), kept_none.data());
        EXPECT_TRUE(fill.fills_trunk());
        level = fill.fill_levels.at(0);
    }
    /// Each vertex's distance from the tube's bones (its spine), over its rest distance.
    std::vector<double> ratios(const std::vector<float>& p, double degrees) const {
        const double t = glm::radians(degrees);
        const dvec3 joint(1, 0, 0), end = joint + dvec3(std::cos(t), std::sin(t), 0);
        std::vector<double> r;
        for (int v = 0; v < tube.vertex_count(); ++v) {
            const dvec3 q0(rest[3 * v], rest[3 * v + 1], rest[3 * v + 2]), q(p[3 * v], p[3 * v + 1], p[3 * v + 2]);
            const double d0 =
                std::min(segment_distance(q0, dvec3(0.0), joint), segment_distance(q0, joint, dvec3(2, 0, 0)));
            const double d = std::min(segment_distance(q, dvec3(0.0), joint), segment_distance(q, joint, end));
            r.push_back(d / d0);
        }
        return r;
    }
    double volume(const std::vector<float>& p) const {
        const anatomy::MeshTopology mesh = anatomy::MeshTopology::build(
            tube.vertex_count(), triangles.data(), static_cast<int>(triangles.size() / 3), rest.data());
        std::vector<int32_t> all(triangles.size() / 3);
        for (size_t t = 0; t < all.size(); ++t) all[t] = static_cast<int32_t>(t);
        return anatomy::ClosedRegion(mesh, all).volume(p.data());
    }
};

TEST(TrunkFill, AtRestNothingMovesBitForBit) {
    test::Arm tube(0.6, 0.5);
    Deformer fill(tube.rig, tube.bind()), plain(tube.rig, tube.bind());
    fill.set_skin_triangles(tube.ring_triangles());
    const std::vector<float> pose = tube.pose(0.0);
    std::vector<float> a(tube.mesh.size()), b(tube.mesh.size());
    fill.deform(pose.data(), a.data());
    plain.deform(pose.data(), b.data());
    EXPECT_EQ(a, b);
    EXPECT_EQ(fill.fill_levels.at(0), 1.0);
}

TEST(TrunkFill, ABentTubeIsFilledToOneLevelAndKeepsItsVolume) {
    const double degrees = 90.0;
    const BentTube bent(degrees);
    const std::vector<double> filled = bent.ratios(bent.filled, degrees), none = bent.ratios(bent.kept_none, degrees),
                              grown = bent.ratios(bent.grown, degrees);
    EXPECT_GT(bent.level, 1.005);
    EXPECT_LT(bent.level, kHighestFillLevel);
    const double v0 = bent.volume(bent.rest);
    const double lost = bent.volume(bent.kept_none) / v0 - 1.0, kept = bent.volume(bent.filled) / v0 - 1.0;
    std::printf(
        "tube bent %.0f deg: level %.4f; volume %+.2f %% with none kept, %+.2f %% filled, %+.2f %% grown; "
        "largest distance ratio %.4f filled, %.4f grown, %.4f with none kept\n",
        degrees, bent.level, 100.0 * lost, 100.0 * kept, 100.0 * (bent.volume(bent.grown) / v0 - 1.0),
        *std::max_element(filled.begin(), filled.end()), *std::max_element(grown.begin(), grown.end()),
        *std::max_element(none.begin(), none.end()));
    EXPECT_LT(lost, -0.01) << "the bend must lose volume for this test to say anything";
    EXPECT_LT(std::abs(kept), 0.25 * std::abs(lost)) << "the fill puts most of it back";
    for (int v = 0; v < bent.tube.vertex_count(); ++v) {
        // No skin ends further from the spine than the level (its own raise goes no further),
        // and skin the bend left further out than that does not move.
        EXPECT_LE(filled[v], std::max(bent.level, none[v]) + 1e-4) << "vertex " << v;
        if (none[v] > bent.level + 1e-4)
            for (int k = 0; k < 3; ++k) EXPECT_EQ(bent.filled[3 * v + k], bent.kept_none[3 * v + k]) << "vertex " << v;
    }
    // Grown by its sections the tube's skin went further out for the same volume.
    EXPECT_LT(*std::max_element(filled.begin(), filled.end()), *std::max_element(grown.begin(), grown.end()));
}

TEST(TrunkFill, AMeshFilledAsAnothersStaysWithIt) {
    // The tube's every other ring bound alone (a mesh bound through the tube's map, its points
    // on the tube) and filled as the tube is: at the tube's level, its points where the tube's are.
    const test::Arm tube(0.6, 0.5);
    Deformer source(tube.rig, tube.bind());
    source.set_skin_triangles(tube.ring_triangles());
    std::vector<int32_t> kept;
    for (int r = 0; r < tube.rings; r += 2)
        for (int k = 0; k < tube.ring_size; ++k) kept.push_back(r * tube.ring_size + k);
    Deformer points(tube.rig, binding_of_vertices(tube.bind(), kept));
    points.fill_trunk_as(source);
    EXPECT_TRUE(points.fills_trunk());
    const std::vector<float> pose = tube.pose(glm::radians(90.0));
    std::vector<float> all(tube.mesh.size()), some(3 * kept.size()), unfilled(3 * kept.size());
    source.deform(pose.data(), all.data());
    points.deform(pose.data(), some.data());
    Deformer plain(tube.rig, binding_of_vertices(tube.bind(), kept));
    plain.deform(pose.data(), unfilled.data());
    EXPECT_GT(source.fill_levels.at(0), 1.005);
    EXPECT_NEAR(points.fill_levels.at(0), source.fill_levels.at(0), 1e-9);
    double moved = 0.0;
    for (size_t i = 0; i < kept.size(); ++i)
        for (int k = 0; k < 3; ++k) {
            EXPECT_NEAR(some[3 * i + k], all[3 * kept[i] + k], 1e-6) << "point " << i;
            moved = std::max(moved, static_cast<double>(std::abs(some[3 * i + k] - unfilled[3 * i + k])));
        }
    EXPECT_GT(moved, 1e-3) << "the fill must move the points for this test to say anything";
    // Another rig's deformer is refused, and a source without triangles fills nothing.
    const test::Arm thin;
    Deformer other(thin.rig, thin.bind());
    EXPECT_THROW(points.fill_trunk_as(other), InvalidInput);
    Deformer bare(tube.rig, tube.bind());
    points.fill_trunk_as(bare);
    EXPECT_FALSE(points.fills_trunk());
}

}  // namespace
}  // namespace sd
