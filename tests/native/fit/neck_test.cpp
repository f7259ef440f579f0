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

INSTANTIATE_TEST_SUITE_P(Characters, NeckTwist,
                         ::testing::Values(NeckCase{"mh_male_game_engine.glb", "neck_01", "head"},
                                           NeckCase{"CesiumMan.glb", "Skeleton_neck_joint_1",
                                                    "Skeleton_neck_joint_2"}));

}  // namespace
}  // namespace sd
