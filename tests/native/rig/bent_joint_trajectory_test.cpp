// A limb's trajectory at a bent joint (rig/bent_joint_trajectory.h): the paper's cubic with the
// joint key's tangent shortened up to a right angle, on the synthetic arm (keys a third apart,
// half-axes 0.10 x 0.07: a thin joint).
#include "rig/bent_joint_trajectory.h"
#include "rig/key_pose.h"
#include "test_arm.h"

#include <gtest/gtest.h>

#include <cmath>

namespace sd {
namespace {

constexpr double kPi = 3.14159265358979323846;

/// The posed geometry of the arm's sweep, the paper's cubic or the tightened one.
SweepGeometry posed_arm(const test::Arm& arm, double bend, double twist, bool tightened) {
    SkeletonPose pose;
    const std::vector<float> bones = arm.pose(bend, twist);
    pose.set(arm.rig.skeleton, bones.data());
    std::vector<dvec3> centers;
    std::vector<dquat> rotations;
    pose_keys(arm.rig.sweeps[0], pose, centers, rotations);
    SweepGeometry g(centers, rotations);
    if (tightened) tighten_bent_joints(arm.rig.sweeps[0], g);
    return g;
}

/// How far the trajectory's span before the elbow (from the last upper-arm key to the elbow
/// key) strays from the upper arm's line, the x axis.
double off_the_upper_arm(const SweepGeometry& g) {
    double most = 0.0;
    for (int i = 0; i <= 100; ++i) {
        const dvec3 c = g.center(2, i / 100.0);
        most = std::max(most, std::hypot(c.y, c.z));
    }
    return most;
}

bool same_spans(const SweepGeometry& a, const SweepGeometry& b) {
    for (int s = 0; s < a.span_count(); ++s)
        for (int i = 0; i < 4; ++i)
            if (a.center_span(s).c[i] != b.center_span(s).c[i]) return false;
    return true;
}

TEST(BentJointTrajectory, TheCutGrowsWithTheBendSinceRestAndFadesPastARightAngleAndOnAThickJoint) {
    const double right = 0.5 * kPi;
    EXPECT_EQ(bent_joint_tangent_cut(right, 0.0, 0.3), 0.0);             // at rest
    EXPECT_NEAR(bent_joint_tangent_cut(right, right, 0.3), 0.4, 1e-12);  // 0.8 sin^2(45°)
    EXPECT_NEAR(bent_joint_tangent_cut(right, 0.25 * kPi, 0.3), 0.8 * std::pow(std::sin(kPi / 8), 2), 1e-12);
    EXPECT_LT(bent_joint_tangent_cut(1.8, 1.8, 0.3), 0.8 * std::pow(std::sin(0.9), 2));  // fading past 90°
    EXPECT_EQ(bent_joint_tangent_cut(2.0 * kPi / 3.0, 2.0 * kPi / 3.0, 0.3), 0.0);       // gone at 120°
    EXPECT_EQ(bent_joint_tangent_cut(right, right, 0.5), 0.0);                           // a thick joint
    EXPECT_LT(bent_joint_tangent_cut(right, right, 0.46), 0.4);
}

TEST(BentJointTrajectory, AnElbowAtARightAngleComesIntoTheJointNearerTheUpperArmsLine) {
    // The paper's cubic bulges outside the corner: a Hermite span with the bisector's tangent,
    // as long as the span, by 0.148 sin 45° of its length (1/3), 3.5 % of the link; the C2
    // spline's tangents, a little shorter, 2.8 %. A 0.4 shorter tangent at the elbow takes a
    // third of that off (the rest comes from the span's other end).
    const test::Arm arm;
    const SweepGeometry paper = posed_arm(arm, 0.5 * kPi, 0.0, false);
    const SweepGeometry tight = posed_arm(arm, 0.5 * kPi, 0.0, true);
    const double before = off_the_upper_arm(paper), after = off_the_upper_arm(tight);
    EXPECT_GT(before, 0.025);
    EXPECT_LT(before, 0.148 * std::sin(0.25 * kPi) / 3.0);
    EXPECT_LT(after / before, 0.7);
    // The keys stay where they are, and the trajectory's direction at the elbow with them.
    for (int s = 0; s < paper.span_count(); ++s) {
        EXPECT_LT(glm::length(tight.center(s, 0.0) - paper.center(s, 0.0)), 1e-12);
        EXPECT_LT(glm::length(tight.center(s, 1.0) - paper.center(s, 1.0)), 1e-12);
    }
    const dvec3 t0 = glm::normalize(paper.tangent(3, 0.0)), t1 = glm::normalize(tight.tangent(3, 0.0));
    const dvec3 t2 = glm::normalize(tight.tangent(2, 1.0));
    EXPECT_LT(glm::length(t1 - t0), 1e-9);
    EXPECT_LT(glm::length(t2 - t1), 1e-9);  // still continuous at the elbow
    EXPECT_NEAR(glm::length(tight.tangent(3, 0.0)) / glm::length(paper.tangent(3, 0.0)), 0.6, 1e-9);
}

TEST(BentJointTrajectory, TheRestPoseATwistADeepBendAndAThickJointKeepThePapersCubic) {
    const test::Arm arm;
    EXPECT_TRUE(same_spans(posed_arm(arm, 0.0, 0.0, false), posed_arm(arm, 0.0, 0.0, true)));
    EXPECT_TRUE(same_spans(posed_arm(arm, 0.0, kPi, false), posed_arm(arm, 0.0, kPi, true)));
    EXPECT_TRUE(
        same_spans(posed_arm(arm, glm::radians(150.0), 0.0, false), posed_arm(arm, glm::radians(150.0), 0.0, true)));
    EXPECT_FALSE(
        same_spans(posed_arm(arm, glm::radians(60.0), 0.0, false), posed_arm(arm, glm::radians(60.0), 0.0, true)));
    // An arm as thick as a third of its link (fold 0.3 x 90° / (2/3) = 0.71) keeps it at 90° too.
    const test::Arm thick(0.3, 0.3);
    EXPECT_TRUE(same_spans(posed_arm(thick, 0.5 * kPi, 0.0, false), posed_arm(thick, 0.5 * kPi, 0.0, true)));
}

}  // namespace
}  // namespace sd
