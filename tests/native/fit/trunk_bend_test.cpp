// The trunk bent forward further than the instrument's 45 degrees (skineval spine_bend_45), as an
// animator bends a character to pick something up, or bends its upper spine alone: the belly
// must neither fold into itself nor swell into a belt. The volume the bend takes from the trunk
// is given back, partly on the inside of the bend (docs/math.md); where the bend is sharp for the
// body's depth that filled a fold that was already closing: MakeHuman's belly creased by 125
// degrees at 60 degrees (linear blend skinning 40) and by 105 at 45 degrees over the upper spine
// alone (43), and with the inside share faded the volume still came back as a belt across the
// belly (its skin 1.44x its rest distance from the spine; 1.12 for linear blend skinning) until
// it was spread along the trunk. Nor may the trunk lose its volume. Since the twenty-fifth
// session that volume is given to the skin (deform/trunk_fill.h), not grown into the sections.
#include "character_fit.h"
#include "dihedral.h"
#include "turned_pose.h"
#include "deform/deform.h"
#include "geometry/mesh_volume.h"
#include "math/segment_distance.h"

#include <sweepdeform_io/gltf_loader.h>

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <limits>
#include <string>
#include <vector>

namespace sd {
namespace {

constexpr double kPi = 3.14159265358979323846;

struct Bend {
    const char* what;
    std::vector<const char*> bones;  // each turned by `degrees` more than the one before
    double degrees;
};

void PrintTo(const Bend& b, std::ostream* os) { *os << b.what; }

class TrunkBend : public ::testing::TestWithParam<Bend> {};

TEST_P(TrunkBend, TheBellyNeitherFoldsNorSwells) {
    const Bend& bend = GetParam();
    const std::string path = std::string(SWEEPDEFORM_SHARED_DATA_DIR) + "/humans/mh_male_game_engine.glb";
    if (!std::filesystem::exists(path)) GTEST_SKIP() << "../shared/data not found (" << path << "): skipped";
    const character_fit::Fitted fitted = character_fit::fit_and_bind(io::load_gltf_character(path));
    const io::Character& c = fitted.character;
    const Skeleton& s = fitted.skeleton;
    const dvec3 left = fitted.fit.chains.frame.left;

    // Each bone and everything below it turned about the body's left through its head, on top
    // of the turns of the bones above it (forward kinematics): the trunk bent forward.
    std::vector<int> turned;
    for (const char* name : bend.bones) turned.push_back(character_fit::bone_named(c, name));
    std::vector<float> pose;
    for (int b = 0; b < s.bone_count(); ++b) {
        dmat4 m(1.0);
        for (int t : turned) {
            bool below = false;
            for (int x = b; x >= 0 && !below; x = s.parents[x]) below = x == t;
            if (below) m = m * testing::turn_about(s.heads[t], left, glm::radians(bend.degrees));
        }
        m = m * s.rest[b];
        for (int col = 0; col < 4; ++col)
            for (int row = 0; row < 4; ++row) pose.push_back(static_cast<float>(m[col][row]));
    }
    // The trunk's skin: vertices whose heaviest bone is one of the trunk's (pelvis to chest).
    const int V = static_cast<int>(c.positions.size() / 3);
    std::vector<int> trunk;
    for (const char* name : {"pelvis", "spine_01", "spine_02", "spine_03"})
        trunk.push_back(character_fit::bone_named(c, name));
    std::vector<char> watched(V, 0);
    for (int v = 0; v < V; ++v) {
        int heaviest = 0;
        for (int i = 1; i < 4; ++i)
            if (c.skin_weights[4 * v + i] > c.skin_weights[4 * v + heaviest]) heaviest = i;
        for (int t : trunk) watched[v] = watched[v] || c.skin_joints[4 * v + heaviest] == t;
    }
    std::vector<float> out(c.positions.size()), lbs(c.positions.size());
    fitted.deformer->deform(pose.data(), out.data());
    character_fit::skin_linearly(c, s, pose.data(), lbs.data());
    const double sweep = glm::degrees(testing::max_dihedral_change(c, out, watched));
    const double skinning = glm::degrees(testing::max_dihedral_change(c, lbs, watched));
    // How far the trunk's skin moves away from its spine (the instrument's r_max): a belt of
    // restored volume across the belly (a ridge, no crease) shows here.
    std::vector<int> spine_bones;
    for (const char* name : {"pelvis", "spine_01", "spine_02", "spine_03"})
        spine_bones.push_back(character_fit::bone_named(c, name));
    SkeletonPose posed;
    posed.set(s, pose.data());
    std::vector<std::array<dvec3, 2>> rest_segments, posed_segments;
    for (int sb : spine_bones) {
        rest_segments.push_back({s.heads[sb], s.tails[sb]});
        posed_segments.push_back(
            {dvec3(posed.deform[sb] * dvec4(s.heads[sb], 1.0)), dvec3(posed.deform[sb] * dvec4(s.tails[sb], 1.0))});
    }
    const auto spine_distance = [](const dvec3& p, const std::vector<std::array<dvec3, 2>>& segments) {
        double d = std::numeric_limits<double>::infinity();
        for (const auto& [head, tail] : segments) d = std::min(d, segment_distance(p, head, tail));
        return d;
    };
    double rmax = 0.0, rmax_lbs = 0.0;
    for (int v = 0; v < V; ++v) {
        if (!watched[v]) continue;
        const dvec3 p0(c.positions[3 * v], c.positions[3 * v + 1], c.positions[3 * v + 2]);
        const double d0 = spine_distance(p0, rest_segments);
        if (d0 < 0.03) continue;
        rmax = std::max(rmax, spine_distance(dvec3(out[3 * v], out[3 * v + 1], out[3 * v + 2]), posed_segments) / d0);
        rmax_lbs =
            std::max(rmax_lbs, spine_distance(dvec3(lbs[3 * v], lbs[3 * v + 1], lbs[3 * v + 2]), posed_segments) / d0);
    }
    // The trunk's volume (its triangles, capped where they meet the limbs, neck and hips): the
    // bend takes it from the belly; the trunk keeps most of it where linear blend skinning
    // loses it all.
    const int T = static_cast<int>(c.triangles.size() / 3);
    const anatomy::MeshTopology mesh = anatomy::MeshTopology::build(V, c.triangles.data(), T, c.positions.data());
    std::vector<int32_t> trunk_triangles;
    for (int t = 0; t < T; ++t)
        if (watched[c.triangles[3 * t]] && watched[c.triangles[3 * t + 1]] && watched[c.triangles[3 * t + 2]])
            trunk_triangles.push_back(t);
    const anatomy::ClosedRegion region(mesh, trunk_triangles);
    const double v_rest = region.volume(c.positions.data());
    const double kept = region.volume(out.data()) / v_rest - 1.0, kept_lbs = region.volume(lbs.data()) / v_rest - 1.0;
    std::printf(
        "%s: largest crease of the trunk %.1f deg (linear blend skinning %.1f), r_max %.3f (%.3f), "
        "volume %+.2f %% (%+.2f %%)\n",
        bend.what, sweep, skinning, rmax, rmax_lbs, 100.0 * kept, 100.0 * kept_lbs);
    // A fold turns the skin back on itself: more than a right angle.
    EXPECT_LT(sweep, 90.0) << "the trunk's skin folds";
    // A belt of restored volume across the belly is no fold but pushes the skin out from the
    // spine: 1.44x its rest distance at 60 degrees when the hold was kept there. The
    // instrument's 45 degree bend, with the hold in full, reached 1.19; with the sections grown
    // by the restoration 1.11-1.20 (60 degrees); with the skin filled instead (trunk_fill.h,
    // the twenty-fifth session) 1.11-1.14.
    EXPECT_LT(rmax, 1.18) << "the trunk's skin bulges away from the spine";
    // Fading the whole restoration with the inside share (as the belt once made us do) lost
    // the trunk's volume as linear blend skinning does: -10.9 % at 60 degrees (-12.3 %). Filled,
    // the trunk gains: +1.1 % at 45 degrees, +3.7 % at 60 (grown by its sections +0.6 and
    // +2.4 %: less of the growth reached the skin), the volume the sweep's restoration asks
    // for (deform.cpp) being more than this region lost.
    EXPECT_GT(kept, -0.03) << "the trunk loses its volume";
    EXPECT_LT(kept, 0.045) << "the trunk swells";
}

INSTANTIATE_TEST_SUITE_P(
    MakeHuman, TrunkBend,
    ::testing::Values(Bend{"bent 45 deg over three spine bones", {"spine_01", "spine_02", "spine_03"}, 15.0},
                      Bend{"bent 52.5 deg over three spine bones", {"spine_01", "spine_02", "spine_03"}, 17.5},
                      Bend{"bent 60 deg over three spine bones", {"spine_01", "spine_02", "spine_03"}, 20.0},
                      Bend{"bent 45 deg over the upper two", {"spine_02", "spine_03"}, 22.5}));

}  // namespace
}  // namespace sd
