// Region weights (Sect. 3.5): where two sweeps meet, the split of a vertex between them is
// smoothed so the transition is gradual, and the smoothing reaches a distance set by the body's
// size, not by how finely its mesh is cut. An analytic strip cut finely and coarsely first,
// then CesiumMan, whose thigh has a ring of vertices every 5-8 cm.
#include "character_fit.h"
#include "fit/fit_rig.h"
#include "fit/regions.h"
#include "geometry/mesh.h"

#include <sweepdeform_io/gltf_loader.h>

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>

namespace sd {
namespace {

/// A flat strip 10 cm wide from x = -0.3 to 0.3 m, columns every `step` metres, rows every
/// 2 cm, with the share (1, 0) before x = 0 and (0, 1) from there on: a hard border between
/// two sweeps, as skin weights that switch at once give it.
struct Strip {
    std::vector<float> positions;
    std::vector<int32_t> triangles;
    std::vector<float> shares;  // #V*2
    std::vector<double> x;
    Strip(double step) {
        const int columns = static_cast<int>(std::lround(0.6 / step)) + 1, rows = 6;
        for (int c = 0; c < columns; ++c)
            for (int r = 0; r < rows; ++r) {
                const double px = -0.3 + c * step;
                positions.insert(positions.end(), {static_cast<float>(px), static_cast<float>(0.02 * r), 0.0f});
                x.push_back(px);
                shares.insert(shares.end(), {px < 0.0 ? 1.0f : 0.0f, px < 0.0 ? 0.0f : 1.0f});
            }
        for (int c = 0; c + 1 < columns; ++c)
            for (int r = 0; r + 1 < rows; ++r) {
                const int a = c * rows + r, b = a + rows;
                triangles.insert(triangles.end(), {a, b, a + 1, b, b + 1, a + 1});
            }
    }
    /// The largest share of the first sweep at or beyond `at` metres past the border.
    double reach_of_first(const std::vector<float>& s, double at) const {
        double most = 0.0;
        for (size_t v = 0; v < x.size(); ++v)
            if (x[v] >= at) most = std::max(most, static_cast<double>(s[2 * v]));
        return most;
    }
};

std::vector<float> smoothed(const Strip& s, double reach) {
    const fit::FitMesh mesh(static_cast<int>(s.x.size()), s.positions.data(), static_cast<int>(s.triangles.size() / 3),
                            s.triangles.data());
    std::vector<float> values = s.shares;
    const fit::RegionOptions o;
    fit::smooth_rows(mesh, 2, values, std::vector<char>(s.x.size(), 1), o.smoothing_iterations, o.smoothing_step,
                     reach);
    return values;
}

TEST(RegionsAnalytic, TheSmoothingReachesADistanceNotANumberOfRings) {
    const double reach = 0.027;  // kSmoothingReachOfDiagonal of a 1.8 m body's 2.16 m diagonal
    const Strip fine(0.01), coarse(0.06);
    // Counted in rings, six passes carry the first sweep's share two columns on: 2 cm on the
    // fine strip, 12 cm on the coarse one.
    EXPECT_LT(fine.reach_of_first(smoothed(fine, 0.0), 0.04), 0.03);
    EXPECT_GT(coarse.reach_of_first(smoothed(coarse, 0.0), 0.12), 0.05);
    // With the reach, the coarse strip's share 12 cm past the border is as small as the fine
    // strip's 4 cm past it, and the fine strip, whose edges are all shorter than the reach,
    // is smoothed exactly as before.
    EXPECT_LT(coarse.reach_of_first(smoothed(coarse, reach), 0.12), 0.01);
    EXPECT_EQ(smoothed(fine, reach), smoothed(fine, 0.0));
    // The border is still a gradual change on both: the column just past it takes some share.
    EXPECT_GT(fine.reach_of_first(smoothed(fine, reach), 0.0), 0.1);
    EXPECT_GT(coarse.reach_of_first(smoothed(coarse, reach), 0.0), 0.05);
}

std::string data_file(const std::string& name) { return std::string(SWEEPDEFORM_SHARED_DATA_DIR) + "/humans/" + name; }

// CesiumMan's skin gives the torso 3-4 % of the skin half way down its left thigh. Smoothed over
// six rings of its coarse mesh that became 10-14 %, and flexing the hip 90° pulled that skin up
// to 2.9 cm off the thigh (skineval hip_flex_90: r_max 1.50 against Preserve Volume's 1.39).
TEST(RegionsCharacter, CesiumMansTorsoDoesNotReachDownItsThigh) {
    const std::string path = data_file("CesiumMan.glb");
    if (!std::filesystem::exists(path)) GTEST_SKIP() << "../shared/data not found (" << path << "): skipped";
    const io::Character c = io::load_gltf_character(path);
    const fit::FitResult f = fit::fit_rig(character_fit::fit_input(c));
    const int hips = character_fit::bone_named(c, "Skeleton_torso_joint_1"),
              thigh = character_fit::bone_named(c, "leg_joint_L_1");
    ASSERT_GE(hips, 0);
    ASSERT_GE(thigh, 0);
    int torso = -1;
    for (size_t k = 0; k < f.chains.chains.size(); ++k)
        if (f.chains.chains[k].name == "torso") torso = f.chain_sweep[k];
    ASSERT_GE(torso, 0);
    const Skeleton s = character_fit::skeleton_of(c);
    const dvec3 head = s.heads[thigh], tail = s.tails[thigh];
    const double length = glm::length(tail - head);
    const fit::RegionWeights& w = f.weights;
    int checked = 0;
    double worst = 0.0;
    for (int v = 0; v < static_cast<int>(c.positions.size() / 3); ++v) {
        const dvec3 p(c.positions[3 * v], c.positions[3 * v + 1], c.positions[3 * v + 2]);
        const double along = glm::dot(p - head, tail - head) / (length * length);
        const double off = glm::length(p - head - along * (tail - head));
        if (along < 0.5 || along > 0.9 || off > 0.5 * length) continue;  // the thigh's lower half
        double skin = 0.0, sweep = 0.0;
        for (int i = 0; i < 4; ++i)
            if (c.skin_joints[4 * v + i] == hips) skin += c.skin_weights[4 * v + i];
        for (int i = 0; i < w.sweep_slots; ++i)
            if (w.sweep_ids[static_cast<size_t>(v) * w.sweep_slots + i] == torso)
                sweep += w.sweep_weights[static_cast<size_t>(v) * w.sweep_slots + i];
        worst = std::max(worst, sweep - skin);
        ++checked;
    }
    ASSERT_GT(checked, 10);
    EXPECT_LT(worst, 0.05) << "the torso's sweep share exceeds the skin's own on the lower thigh by " << worst;
}

}  // namespace
}  // namespace sd
