// The neck (Sect. 4.1, departure in docs/math.md): turning the head and neck about the neck
// must turn the neck's skin, not shear it where the neck meets the chest. The neck's first key
// takes the neck's whole twist against the chest, so the twist passes from chest to neck across
// the skin both sweeps share, as Preserve Volume turns it; with half of it at that key and the
// rest one short span up, the neck creased there. Every body of ../shared/data that has a neck
// bone, fitted and bound by the product, neck bones turned 60° (as skineval's neck_twist_60).
#include "character_fit.h"
#include "dihedral.h"
#include "turned_pose.h"
#include "deform/deform.h"

#include <sweepdeform_io/gltf_loader.h>

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>

namespace sd {
namespace {

constexpr double kPi = 3.14159265358979323846;

struct NeckCase {
    const char* file;
    const char* neck;  // the neck bone (its subtree, head included, turns)
    const char* head;
    bool chest_still;  // the chest's skin a neck's length down keeps its place (not CesiumMan's,
                       // whose skin there follows the shoulders' sweeps, which ride the neck)
};

void PrintTo(const NeckCase& c, std::ostream* os) { *os << c.file; }

class NeckTwist : public ::testing::TestWithParam<NeckCase> {};

TEST_P(NeckTwist, TurnsTheNeckWithoutShearingItsBase) {
    const NeckCase& nc = GetParam();
    const std::string path = std::string(SWEEPDEFORM_SHARED_DATA_DIR) + "/humans/" + nc.file;
    if (!std::filesystem::exists(path)) GTEST_SKIP() << "../shared/data not found (" << path << "): skipped";
    const character_fit::Fitted fitted = character_fit::fit_and_bind(io::load_gltf_character(path));
    const io::Character& c = fitted.character;
    const Skeleton& s = fitted.skeleton;
    Deformer& d = *fitted.deformer;
    const int V = static_cast<int>(c.positions.size() / 3);
    const int neck = character_fit::bone_named(c, nc.neck), head = character_fit::bone_named(c, nc.head);
    ASSERT_TRUE(neck >= 0 && head >= 0);

    // The neck and everything above it turned 60° about the line from the neck's base to the
    // head's joint; the skin from a neck's length below the base to the head's joint is watched.
    const dvec3 base = s.heads[neck], top = s.heads[head];
    const dvec3 axis = glm::normalize(top - base);
    const double length = glm::length(top - base);
    const std::vector<float> pose = testing::turned_pose(s, neck, testing::turn_about(base, axis, kPi / 3.0));
    std::vector<char> watched(V, 0);
    for (int v = 0; v < V; ++v) {
        const dvec3 p(c.positions[3 * v], c.positions[3 * v + 1], c.positions[3 * v + 2]);
        const double along = glm::dot(p - base, axis);
        watched[v] = along > -length && along < length && glm::length(p - base - along * axis) < 1.5 * length;
    }
    std::vector<float> out(c.positions.size()), lbs(c.positions.size());
    d.deform(pose.data(), out.data());
    character_fit::skin_linearly(c, s, pose.data(), lbs.data());
    const double sweep = glm::degrees(testing::max_dihedral_change(c, out, watched));
    const double skinning = glm::degrees(testing::max_dihedral_change(c, lbs, watched));
    std::printf("%s: neck turned 60 deg, largest crease at the neck %.1f deg (linear blend skinning %.1f)\n", nc.file,
                sweep, skinning);
    // Within 6° of linear blend skinning's sharpest bend, which turns the neck's skin with its
    // bones (CesiumMan with half the twist at the neck's first key: 43.3° against 24.9°; 28.4°
    // while the armpit's web joined the arms as points, 30.0° since it joins as frames).
    EXPECT_LT(sweep, skinning + 6.0) << "the neck's skin creases more than linear blend skinning's";
}

TEST_P(NeckTwist, KeepsEverySkinPointsDistanceFromTheNeck) {
    // Turned about its own line (as skineval's neck_twist_60 turns it and measures the skin's
    // distance from the segment from the neck's base to the head's joint), the neck carries
    // its skin round that line: every influence of the skin there turns about it, the chest
    // not at all, so no point moves nearer to or farther from it. Before the neck's joint took
    // its twist about the neck (its bisecting normal instead, the chest's end key half of it):
    // 1.0035 on the 13K MakeHuman, 1.023 on CesiumMan, where Preserve Volume keeps 1.0000.
    const NeckCase& nc = GetParam();
    const std::string path = std::string(SWEEPDEFORM_SHARED_DATA_DIR) + "/humans/" + nc.file;
    if (!std::filesystem::exists(path)) GTEST_SKIP() << "../shared/data not found (" << path << "): skipped";
    const character_fit::Fitted fitted = character_fit::fit_and_bind(io::load_gltf_character(path));
    const io::Character& c = fitted.character;
    const Skeleton& s = fitted.skeleton;
    const int neck = character_fit::bone_named(c, nc.neck), head = character_fit::bone_named(c, nc.head);
    ASSERT_TRUE(neck >= 0 && head >= 0);
    const dvec3 base = s.heads[neck], top = s.heads[head];
    const dvec3 axis = glm::normalize(top - base);
    const double length = glm::length(top - base);
    const double turn = kPi / 3.0;
    const std::vector<float> pose = testing::turned_pose(s, neck, testing::turn_about(base, axis, turn));
    std::vector<float> out(c.positions.size()), lbs(c.positions.size());
    fitted.deformer->deform(pose.data(), out.data());
    character_fit::skin_linearly(c, s, pose.data(), lbs.data());
    // The distance to the segment, at rest and posed (the segment turns about itself).
    const auto distance = [&](const dvec3& p) {
        const double t = std::clamp(glm::dot(p - base, axis), 0.0, length);
        return glm::length(p - (base + t * axis));
    };
    double largest = 0.0, moved_below = 0.0;
    for (size_t v = 0; v < c.positions.size() / 3; ++v) {
        const dvec3 p(c.positions[3 * v], c.positions[3 * v + 1], c.positions[3 * v + 2]);
        const dvec3 q(out[3 * v], out[3 * v + 1], out[3 * v + 2]);
        const double d0 = distance(p);
        if (glm::dot(p - base, axis) > -length && d0 < 1.5 * length && d0 > 0.1 * length)
            largest = std::max(largest, distance(q) / d0);
        // The chest a neck's length below its base, where the rig's own weights leave the
        // skin in place (on CesiumMan the arms hang from the neck and turn with it), stays.
        const dvec3 l(lbs[3 * v], lbs[3 * v + 1], lbs[3 * v + 2]);
        if (glm::dot(p - base, axis) < -length && glm::length(l - p) == 0.0)
            moved_below = std::max(moved_below, glm::length(q - p));
    }
    std::printf("%s: neck turned 60 deg, skin's largest distance from the neck %.7f of rest, chest moved %.2g m\n",
                nc.file, largest, moved_below);
    // Float rounding of the positions: a micrometre in a centimetre.
    EXPECT_LT(largest, 1.0 + 1e-4) << "skin moved off the neck's line";
    if (nc.chest_still) EXPECT_LT(moved_below, 1e-5 * length) << "the chest turned with the neck";
}

INSTANTIATE_TEST_SUITE_P(Characters, NeckTwist,
                         ::testing::Values(NeckCase{"mh_male_game_engine.glb", "neck_01", "head", true},
                                           NeckCase{"CesiumMan.glb", "Skeleton_neck_joint_1", "Skeleton_neck_joint_2",
                                                    false}));

}  // namespace
}  // namespace sd
