// The core on real characters from ../shared/data, with key ellipses simply sitting on the
// bones (automatic fitting is tested in fit_test.cpp).
#include "character_fit.h"
#include "bone_rig.h"
#include "deform/deform.h"
#include "point_metrics.h"

#include <sweepdeform_io/animation.h>
#include <sweepdeform_io/gltf_loader.h>

#include <gtest/gtest.h>

#include <filesystem>

namespace sd {
namespace {

using testing::diagonal;

std::string data_file(const std::string& name) { return std::string(SWEEPDEFORM_SHARED_DATA_DIR) + "/humans/" + name; }

#define REQUIRE_DATA(path)              \
    if (!std::filesystem::exists(path)) \
    GTEST_SKIP() << "../shared/data not found (" << path << "): real-character test skipped"

class RealCharacter : public ::testing::TestWithParam<const char*> {};

TEST_P(RealCharacter, RestPoseRoundTripAndPlausibleMotion) {
    const std::string path = data_file(GetParam());
    REQUIRE_DATA(path);
    const io::Character c = io::load_gltf_character(path);
    const testing::BoneRig rig = testing::make_bone_rig(c, testing::makehuman_chains());
    Deformer d(rig.rig, rig.bind(c));
    const int V = static_cast<int>(c.positions.size() / 3);
    std::vector<float> out(c.positions.size());

    d.deform(io::rest_pose(c).data(), out.data());
    const double diag = diagonal(c.positions);
    double worst = 0.0;
    for (int v = 0; v < V; ++v)
        worst =
            std::max(worst, glm::length(dvec3(out[3 * v] - c.positions[3 * v], out[3 * v + 1] - c.positions[3 * v + 1],
                                              out[3 * v + 2] - c.positions[3 * v + 2])));
    std::printf("%s: %d vertices, rest round trip max error %.3g (%.3g x diagonal)\n", GetParam(), V, worst,
                worst / diag);
    EXPECT_LE(worst, 1e-6 * diag);

    // Motion-capture poses of the same skeleton: the result stays close to linear blend
    // skinning on average (same skeleton, same skin), nothing explodes.
    const std::string anims = data_file("mh_male_game_engine_anims.glb");
    if (!std::filesystem::exists(anims)) return;
    const io::Character a = io::load_gltf_character(anims);
    ASSERT_EQ(a.bone_names, c.bone_names);
    std::vector<float> lbs(c.positions.size());
    for (size_t clip = 0; clip < a.animations.size(); ++clip)
        for (double t : {0.5, 2.0, 4.0}) {
            const auto pose = io::sample_pose(a, static_cast<int>(clip), t);
            d.deform(pose.data(), out.data());
            character_fit::skin_linearly(c, rig.rig.skeleton, pose.data(), lbs.data());
            double mean = 0.0, max = 0.0;
            for (int v = 0; v < V; ++v) {
                const double e = glm::length(
                    dvec3(out[3 * v] - lbs[3 * v], out[3 * v + 1] - lbs[3 * v + 1], out[3 * v + 2] - lbs[3 * v + 2]));
                ASSERT_TRUE(std::isfinite(e));
                mean += e / V;
                max = std::max(max, e);
            }
            EXPECT_LT(mean, 0.01 * diag) << a.animations[clip].name << " t=" << t;
            EXPECT_LT(max, 0.1 * diag) << a.animations[clip].name << " t=" << t;
        }
}

INSTANTIATE_TEST_SUITE_P(MakeHuman, RealCharacter,
                         ::testing::Values("mh_male_game_engine.glb", "mh_male_game_engine_subdiv1.glb"));

}  // namespace
}  // namespace sd
