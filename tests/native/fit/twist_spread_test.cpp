// The twist's spread along a limb's last link (fit/twist_spread.h): as the square of the place
// on a mesh with 11.5 rings or more along the link, lowered towards the place itself on
// coarser meshes, so the last gap between rings before the wrist takes at most a sixth of the
// hand's twist. Analytic tubes first, then the shared characters' forearms.
#include "character_fit.h"
#include "fit/twist_spread.h"
#include "geometry/mesh.h"

#include <sweepdeform_io/gltf_loader.h>

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>

namespace sd::fit {
namespace {

constexpr double kPi = 3.14159265358979323846;

/// A tube of radius 3 cm along x, rings every `gap` from x = -0.1 to 0.4 (past both ends of a
/// link from 0 to 0.26), 8 vertices a ring, quads cut into two triangles; chain 0 owns the
/// vertices with x < `owned_to`, chain 1 the rest (a hand beyond the wrist).
struct Tube {
    std::vector<float> positions;
    std::vector<int32_t> triangles;
    PartShares shares;
    Tube(double gap, double owned_to = 1e9) {
        const int rings = static_cast<int>(std::floor(0.5 / gap)) + 1, around = 8;
        shares.chains = 2;
        for (int r = 0; r < rings; ++r)
            for (int i = 0; i < around; ++i) {
                const double x = -0.1 + r * gap, a = 2.0 * kPi * i / around;
                positions.insert(positions.end(), {static_cast<float>(x), static_cast<float>(0.03 * std::cos(a)),
                                                   static_cast<float>(0.03 * std::sin(a))});
                shares.share.insert(shares.share.end(), {x < owned_to ? 1.0f : 0.0f, x < owned_to ? 0.0f : 1.0f});
            }
        for (int r = 0; r + 1 < rings; ++r)
            for (int i = 0; i < around; ++i) {
                const int a = r * around + i, b = r * around + (i + 1) % around;
                triangles.insert(triangles.end(), {a, a + around, b, b, a + around, b + around});
            }
    }
    double rings(int chain = 0) const {
        const FitMesh mesh(static_cast<int>(positions.size() / 3), positions.data(),
                           static_cast<int>(triangles.size() / 3), triangles.data());
        return rings_along(mesh, shares, chain, dvec3(0.0), dvec3(0.26, 0, 0));
    }
};

TEST(TwistSpread, RingsAlongALinkAreItsLengthOverTheGapBetweenThem) {
    // The quads' diagonals run along the link too (5.2 cm gap, 2.3 cm round the ring) and
    // count with the same length along it; the edges round each ring do not count.
    for (double gap : {0.0052, 0.0217, 0.052}) EXPECT_NEAR(Tube(gap).rings(), 0.26 / gap, 1e-4) << gap;
    // Vertices another chain owns (the hand past x = 0.2) are not the link's: with its rings
    // 2 cm apart the link still measures 13 rings, from its own part.
    EXPECT_NEAR(Tube(0.02, 0.2).rings(), 13.0, 1e-4);
    EXPECT_EQ(Tube(0.02).rings(1), 0.0) << "no edges of its own: not measured";
}

TEST(TwistSpread, TheLastGapBeforeTheWristTakesAtMostASixthOfTheTwist) {
    // The square on 11.5 rings or more, the place itself on six or fewer, and in between the
    // power that gives the last gap exactly a sixth: 1 - (1 - 1/n)^p = 1/6.
    EXPECT_EQ(twist_spread_for(12.0), 2.0);
    EXPECT_EQ(twist_spread_for(80.0), 2.0);
    EXPECT_NEAR(twist_spread_for(6.0), 1.0, 1e-12);
    EXPECT_EQ(twist_spread_for(4.9), 1.0);
    EXPECT_EQ(twist_spread_for(0.5), 1.0);
    for (double n : {7.0, 8.5, 10.3, 11.4}) {
        const double p = twist_spread_for(n);
        EXPECT_GT(p, 1.0) << n;
        EXPECT_LT(p, 2.0) << n;
        EXPECT_NEAR(1.0 - std::pow(1.0 - 1.0 / n, p), kLastRingGapShare, 1e-12) << n;
    }
    EXPECT_EQ(twist_spread_for(0.0), kDefaultTwistSpread) << "not measured: the default";
}

TEST(TwistSpread, TheFittingSetsItOnTheEndKeysOfTheSharedCharacters) {
    // The 53.5K MakeHuman male has about 22 rings along each forearm (the square); CesiumMan,
    // a game model, 4.5 and 6.5 (1 and 1.09); every end key gets a spread in [1, 2], the other
    // keys keep the default.
    struct Case {
        const char* file;
        double least, most;  // the forearms' spreads
    };
    for (const Case& k : {Case{"mh_male_game_engine_subdiv1.glb", 2.0, 2.0}, Case{"CesiumMan.glb", 1.0, 1.6}}) {
        const std::string path = std::string(SWEEPDEFORM_SHARED_DATA_DIR) + "/humans/" + k.file;
        if (!std::filesystem::exists(path)) GTEST_SKIP() << "../shared/data not found (" << path << "): skipped";
        const io::Character c = io::load_gltf_character(path);
        const FitResult f = fit_rig(character_fit::fit_input(c));
        int arms = 0;
        for (size_t ch = 0; ch < f.chains.chains.size(); ++ch) {
            const int s = f.chain_sweep[ch];
            if (s < 0) continue;
            const std::vector<KeyEllipse>& keys = f.rig.sweeps[s].keys;
            for (size_t i = 0; i + 1 < keys.size(); ++i) EXPECT_EQ(keys[i].twist_spread, kDefaultTwistSpread);
            const double spread = keys.back().twist_spread;
            EXPECT_GE(spread, 1.0);
            EXPECT_LE(spread, 2.0);
            if (f.chains.chains[ch].kind != ChainKind::Arm) continue;
            ++arms;
            EXPECT_GE(spread, k.least) << k.file << " " << f.chains.chains[ch].name;
            EXPECT_LE(spread, k.most) << k.file << " " << f.chains.chains[ch].name;
        }
        EXPECT_EQ(arms, 2) << k.file;
    }
}

}  // namespace
}  // namespace sd::fit
