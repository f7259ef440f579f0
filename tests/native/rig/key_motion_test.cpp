// How the keys of a thick chain (a trunk) follow its bones, and how a joint key splits its
// joint's turn into swing and twist (rig/key_motion.h, rig/key_pose.h).
#include "rig/key_motion.h"
#include "rig/key_pose.h"
#include "rig/rig.h"
#include "turned_pose.h"

#include <gtest/gtest.h>

#include <glm/gtc/matrix_transform.hpp>

#include <cmath>
#include <map>
#include <vector>

namespace sd {
namespace {

/// Three bones along x, 1, 0.5 and 1.5 long (vertebrae of unequal length), and an intermediate
/// key every `step` along them, half-axes 1: a chain far thicker than its links are long.
struct ThickChain {
    Skeleton skeleton;
    std::vector<KeyEllipse> keys;
    double step = 0.005;

    ThickChain() {
        const std::vector<double> joints{0.0, 1.0, 1.5, 3.0};
        std::vector<dmat4> rest;
        std::vector<dvec3> heads, tails;
        for (int b = 0; b < 3; ++b) {
            heads.emplace_back(joints[b], 0, 0);
            tails.emplace_back(joints[b + 1], 0, 0);
            rest.push_back(glm::translate(dmat4(1.0), heads.back()));
        }
        skeleton = Skeleton::build({-1, 0, 1}, rest, heads, tails);
        for (double x = 0.5 * step; x < 3.0; x += step) {
            KeyEllipse e;
            e.center = dvec3(x, 0, 0);
            e.orientation = glm::angleAxis(glm::radians(90.0), dvec3(0, 1, 0));  // normal along x
            e.a = e.b = 1.0;
            e.bone = x < 1.0 ? 0 : x < 1.5 ? 1 : 2;
            keys.push_back(e);
        }
    }
};

TEST(KeyMotion, ThickChainKeysBlendTheirBonesWithWeightsOfContinuousSlope) {
    // Each bone's weight, read along the chain, has a bounded second derivative (2 / h^2 for a
    // tent of half-width h): no kink where the blend reaches a joint, which drew a band across
    // a bent torso's flank. A box window's weights kink there (their second difference is of
    // the order of step / h, not step^2 / h^2).
    const ThickChain chain;
    const std::vector<KeyMotion> motions = key_motions(chain.keys, chain.skeleton);
    const double h = kThickChainTent * 1.0;  // every key's larger half-axis is 1
    const int K = static_cast<int>(chain.keys.size());
    std::vector<std::map<int, double>> weight(K);
    for (int k = 0; k < K; ++k) {
        double total = 0.0;
        for (const auto& [bone, w] : motions[k].blend) {
            weight[k][bone] = w;
            total += w;
        }
        if (motions[k].blend.empty()) weight[k][chain.keys[k].bone] = total = 1.0;  // rigid
        EXPECT_NEAR(total, 1.0, 1e-12) << "key " << k;
    }
    const auto w = [&](int k, int bone) { return weight[k].count(bone) ? weight[k].at(bone) : 0.0; };
    double worst = 0.0;
    int blended = 0;
    for (int k = 1; k + 1 < K; ++k) {
        if (chain.keys[k - 1].center.x < h) continue;  // the tent is clipped at the chain's start
        blended += motions[k].blend.size() > 1 ? 1 : 0;
        for (int bone = 0; bone < 3; ++bone)
            worst = std::max(worst, std::abs(w(k - 1, bone) - 2.0 * w(k, bone) + w(k + 1, bone)));
    }
    EXPECT_GT(blended, K / 4) << "the chain must be thick, its keys blended";
    EXPECT_LE(worst, 2.0 * chain.step * chain.step / (h * h) * 1.0001);
}

TEST(KeyMotion, ThickChainKeysLeanToTheBoneTheySitOn) {
    // Mid-bone on the long last bone, a key follows that bone most; the middle bone, shorter
    // than the tent, never takes all of a key.
    const ThickChain chain;
    const std::vector<KeyMotion> motions = key_motions(chain.keys, chain.skeleton);
    for (size_t k = 0; k < chain.keys.size(); ++k) {
        const double x = chain.keys[k].center.x;
        double on_own = motions[k].blend.empty() ? 1.0 : 0.0, most = 0.0;
        for (const auto& [bone, w] : motions[k].blend) {
            if (bone == chain.keys[k].bone) on_own = w;
            most = std::max(most, w);
        }
        if (x > 2.0 && x < 2.5) EXPECT_DOUBLE_EQ(on_own, std::max(on_own, most)) << "x " << x;
        if (chain.keys[k].bone == 1) EXPECT_LT(on_own, 1.0) << "x " << x;
    }
}

// An arm's first key (the shoulder) takes half of the swing at rest and across, as the paper's
// joint keys do, all of it as the swing lowers the arm towards the body's down and 0.6 of it as
// the swing raises the arm (trunk.h, set_shoulder_motions): an arm pointing along +x, the body's
// down -z.
TEST(KeyMotion, AShoulderKeyTakesTheWholeSwingAsTheArmIsLoweredAndMoreThanHalfAsItIsRaised) {
    KeyMotion m;
    m.swing_share = 0.5;
    m.axis = dvec3(1, 0, 0);
    m.lowering = dvec3(0, 0, -1);
    m.lowering_share = 1.0;
    m.raising_share = 0.6;
    const auto swing = [](const dvec3& about, double degrees) { return glm::angleAxis(glm::radians(degrees), about); };
    EXPECT_DOUBLE_EQ(shoulder_swing_share(m, swing(dvec3(0, 1, 0), 70.0)), 1.0);   // lowered
    EXPECT_DOUBLE_EQ(shoulder_swing_share(m, swing(dvec3(0, 1, 0), -70.0)), 0.6);  // raised
    EXPECT_DOUBLE_EQ(shoulder_swing_share(m, swing(dvec3(0, 0, 1), 70.0)), 0.5);   // swung forward
    EXPECT_DOUBLE_EQ(shoulder_swing_share(m, dquat(1, 0, 0, 0)), 0.5);             // at rest
    // Continuous and monotonic either way: a degree down or up is barely more than half.
    for (const double sign : {1.0, -1.0}) {
        double before = 0.5;
        for (double deg = 1.0; deg <= 90.0; deg += 1.0) {
            const double share = shoulder_swing_share(m, swing(dvec3(0, 1, 0), sign * deg));
            EXPECT_GE(share, before);
            EXPECT_LT(share - before, 0.05) << sign * deg;
            before = share;
        }
    }
    // Any other joint key keeps its share whatever the swing.
    m.lowering = dvec3(0.0);
    EXPECT_DOUBLE_EQ(shoulder_swing_share(m, swing(dvec3(0, 1, 0), 70.0)), 0.5);
    EXPECT_DOUBLE_EQ(shoulder_swing_share(m, swing(dvec3(0, 1, 0), -70.0)), 0.5);
}

/// A chest bone up the z axis and a neck leaning 17 degrees forward from its tip, and the
/// chest's end key at the joint, its plane bisecting the two (the fitting's gentle joints):
/// its normal is 8.5 degrees off the neck.
struct NeckJoint {
    Skeleton skeleton;
    dvec3 joint{0, 0, 1}, neck = glm::normalize(dvec3(0, -0.3, 1));
    KeyEllipse key;

    NeckJoint() {
        const std::vector<dvec3> heads{dvec3(0.0), joint}, tails{joint, joint + 0.1 * neck};
        skeleton = Skeleton::build(
            {-1, 0}, {glm::translate(dmat4(1.0), heads[0]), glm::translate(dmat4(1.0), heads[1])}, heads, tails);
        const dvec3 normal = glm::normalize(dvec3(0, 0, 1) + neck);
        key.center = joint;
        key.orientation = dquat(dvec3(0, 0, 1), normal);
        key.a = key.b = 0.02;  // a neck, not a trunk: thinner than its links are long
        key.bone = 1;
        key.joint_parent = 0;
    }
    /// The key's turn since rest with the neck turned `degrees` about its own line.
    dquat turn(double degrees) const {
        Rig rig;
        rig.skeleton = skeleton;
        KeyEllipse below = key, above = key;
        below.center = dvec3(0, 0, 0.5);
        below.orientation = dquat(1, 0, 0, 0);
        below.bone = 0;
        below.joint_parent = -1;
        above.center = joint + 0.05 * neck;
        above.orientation = dquat(dvec3(0, 0, 1), neck);
        above.joint_parent = -1;
        rig.add_sweep({below, key, above});
        SkeletonPose pose;
        const std::vector<float> m =
            testing::turned_pose(skeleton, 1, testing::turn_about(joint, neck, glm::radians(degrees)));
        pose.set(skeleton, m.data());
        std::vector<dvec3> centers;
        std::vector<dquat> rotations;
        pose_keys(rig.sweeps[0], pose, centers, rotations);
        return rotations[1] * glm::conjugate(key.orientation);
    }
};

/// The angle (degrees) between `turn`'s axis and `axis` (either sense).
double off_axis_degrees(const dquat& turn, const dvec3& axis) {
    const dvec3 v(turn.x, turn.y, turn.z);
    return glm::degrees(std::acos(std::min(1.0, std::abs(glm::dot(glm::normalize(v), axis)))));
}

TEST(KeyMotion, AJointKeyTakesItsTwistAboutItsTwistDirection) {
    // The neck turned 60 degrees about its own line: with the twist taken about the neck
    // (the fitting's twist direction at the neck's joint), all of the turn is twist, and the
    // key turns about the neck by its twist share: half, all (the neck's first key), none (the
    // chest's end key).
    NeckJoint j;
    j.key.twist_direction = j.neck;
    for (const double share : {0.5, 1.0}) {
        j.key.twist_fraction = share;
        const dquat t = j.turn(60.0);
        EXPECT_NEAR(glm::degrees(glm::angle(t)), 60.0 * share, 1e-5) << share;  // the pose is float
        EXPECT_LT(off_axis_degrees(t, j.neck), 1e-4) << share;
    }
    j.key.twist_fraction = 0.0;
    EXPECT_NEAR(glm::angle(j.turn(60.0)), 0.0, 1e-7);
    // About the key's normal (no twist direction, as blobs before version 4), the same turn
    // reads partly as swing, and the key turns about a line off the neck: the skin between
    // it and the neck's keys does not turn about the neck.
    j.key.twist_direction = dvec3(0.0);
    j.key.twist_fraction = 0.0;
    EXPECT_GT(glm::degrees(glm::angle(j.turn(60.0))), 1.0);
    j.key.twist_fraction = 1.0;
    EXPECT_GT(off_axis_degrees(j.turn(60.0), j.neck), 1.0);
}

}  // namespace
}  // namespace sd
