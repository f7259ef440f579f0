// The mesh's volume at the joints (joint_volume.h): the cone volume, the table's reading, and
// the synthetic arm whose mesh keeps its volume at bends the table was not measured at.
#include "deform/joint_volume.h"

#include "character_fit.h"
#include "bind/serialize.h"
#include "deform/deform.h"
#include "deform/joint_volume_blob.h"
#include "fit/fit_rig.h"
#include "test_arm.h"
#include "turned_pose.h"

#include <sweepdeform_io/animation.h>
#include <sweepdeform_io/gltf_loader.h>

#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <string>
#include <vector>

namespace sd {
namespace {

constexpr double kPi = 3.14159265358979323846;

// A unit cube's 8 corners and 12 outward triangles.
const std::vector<float> kCube = {0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0, 0, 0, 1, 1, 0, 1, 1, 1, 1, 0, 1, 1};
const std::vector<int32_t> kCubeTriangles = {0, 2, 1, 0, 3, 2, 4, 5, 6, 4, 6, 7, 0, 1, 5, 0, 5, 4,
                                             1, 2, 6, 1, 6, 5, 2, 3, 7, 2, 7, 6, 3, 0, 4, 3, 4, 7};

TEST(JointVolume, ConeVolumeOfAClosedSurfaceIsItsVolumeFromAnyApex) {
    EXPECT_NEAR(cone_volume(kCube.data(), kCubeTriangles, dvec3(0.0)), 1.0, 1e-12);
    EXPECT_NEAR(cone_volume(kCube.data(), kCubeTriangles, dvec3(5, -3, 2)), 1.0, 1e-12);
    EXPECT_NEAR(cone_volume(kCube.data(), kCubeTriangles, dvec3(0.5, 0.5, 0.5)), 1.0, 1e-12);
}

// The arm's elbow as a table: the forearm (bone 1) against the upper arm (bone 0), axis +x,
// direction 0 towards +y. Row i (bend 45° (i + 1)) goes round the axis as
// (i + 1) (2 + cos(direction - 0.3) + 0.5 sin(2 direction)): a loss one way, a gain the other.
double numbered(int row, double direction) {
    return (row + 1) * (2.0 + std::cos(direction - 0.3) + 0.5 * std::sin(2.0 * direction));
}

JointVolumeTable numbered_elbow() {
    JointVolumeTable t;
    t.sweep = 0;
    t.key = 3;
    t.parent = 0;
    t.child = 1;
    t.axis = dvec3(1, 0, 0);
    t.e1 = dvec3(0, 1, 0);
    t.e2 = dvec3(0, 0, 1);
    for (int i = 0; i < JointVolumeTable::kSwings; ++i)
        for (int j = 0; j < JointVolumeTable::kDirections; ++j)
            t.added.push_back(numbered(i, 2.0 * kPi * j / JointVolumeTable::kDirections));
    t.most_added = 100.0;
    return t;
}

// The table read with the forearm bent by `bend` towards direction `direction` (about +x).
double read_at(const JointVolumeTable& t, const test::Arm& arm, double bend, double direction = 0.0,
               const dvec3& lowering = dvec3(0.0)) {
    const dvec3 elbow(1, 0, 0), towards(0, std::cos(direction), std::sin(direction));
    const std::vector<float> pose = testing::turned_pose(
        arm.rig.skeleton, 1, testing::turn_about(elbow, glm::cross(dvec3(1, 0, 0), towards), bend));
    SkeletonPose sp;
    sp.set(arm.rig.skeleton, pose.data());
    return t.added_volume(sp, lowering);
}

TEST(JointVolume, TheTableReadsNothingAtRestItsSamplesAtTheirBendsAndASineBetween) {
    const test::Arm arm;
    const JointVolumeTable t = numbered_elbow();
    constexpr double kTol = 1e-5;  // the poses are float32
    EXPECT_NEAR(read_at(t, arm, 0.0), 0.0, 1e-12);
    EXPECT_NEAR(read_at(t, arm, kPi / 4), numbered(0, 0.0), kTol);
    EXPECT_NEAR(read_at(t, arm, kPi / 8), 0.5 * numbered(0, 0.0), kTol);  // half way from no bend
    EXPECT_NEAR(read_at(t, arm, 3 * kPi / 8), 0.5 * (numbered(0, 0.0) + numbered(1, 0.0)), kTol);
    EXPECT_NEAR(read_at(t, arm, 3 * kPi / 4), numbered(2, 0.0), kTol);
    EXPECT_NEAR(read_at(t, arm, 0.95 * kPi), numbered(2, 0.0), kTol);  // held beyond the last row
    // Round the axis, between the samples: the sine itself.
    for (double direction : {0.4, 1.9, 3.5, -2.2})
        EXPECT_NEAR(read_at(t, arm, kPi / 2, direction), numbered(1, direction), kTol) << direction;
    // Where the row goes below zero, nothing is added.
    JointVolumeTable lower = t;
    for (double& v : lower.added) v -= 6.0;
    EXPECT_NEAR(read_at(lower, arm, kPi / 2, 0.3), numbered(1, 0.3) - 6.0, kTol);
    EXPECT_EQ(read_at(lower, arm, kPi / 2, 0.3 + kPi), 0.0);
    // And never more than the bound.
    lower.most_added = 0.01;
    EXPECT_EQ(read_at(lower, arm, kPi / 2, 0.3), 0.01);
}

TEST(JointVolume, AShouldersTableAddsNothingAsTheArmIsLoweredTowardsTheBody) {
    // The same table as a shoulder's whose body's down is +y (direction 0): lowered towards it,
    // nothing once the link's direction has come kLoweredWithoutGrowth of the way down, half
    // at half that, the whole reading raised away from it or swung across it.
    const test::Arm arm;
    const JointVolumeTable t = numbered_elbow();
    const dvec3 down(0, 1, 0);
    constexpr double kTol = 1e-5;
    EXPECT_EQ(read_at(t, arm, kPi / 4, 0.0, down), 0.0);
    EXPECT_EQ(read_at(t, arm, 3 * kPi / 4, 0.0, down), 0.0);
    const double half = std::asin(0.5 * kLoweredWithoutGrowth);  // lowered by half the fade
    EXPECT_NEAR(read_at(t, arm, half, 0.0, down), 0.5 * read_at(t, arm, half, 0.0), kTol);
    EXPECT_NEAR(read_at(t, arm, kPi / 4, kPi, down), read_at(t, arm, kPi / 4, kPi), 1e-12);         // raised
    EXPECT_NEAR(read_at(t, arm, kPi / 2, kPi / 2, down), read_at(t, arm, kPi / 2, kPi / 2), kTol);  // across
    EXPECT_GT(read_at(t, arm, kPi / 2, kPi / 2, down), 0.0);
    // Continuous in the swing: no step where the fade begins or ends.
    const double end = std::asin(kLoweredWithoutGrowth);
    EXPECT_LT(read_at(t, arm, 0.999 * end, 0.0, down), 1e-2 * read_at(t, arm, end, 0.0));
    EXPECT_NEAR(read_at(t, arm, 1e-4, kPi / 2 - 1e-3, down), read_at(t, arm, 1e-4, kPi / 2 - 1e-3), 1e-4);
}

TEST(JointVolume, TablesNameTheRigsSweepsAndBones) {
    const test::Arm arm;
    Deformer d(arm.rig, arm.bind());
    JointVolumeTable bad = numbered_elbow();
    bad.child = 7;
    EXPECT_THROW(d.set_joint_volumes({bad}), InvalidInput);
    bad = numbered_elbow();
    bad.added.pop_back();
    EXPECT_THROW(d.set_joint_volumes({bad}), InvalidInput);
    bad = numbered_elbow();
    bad.key = 7;
    EXPECT_THROW(d.set_joint_volumes({bad}), InvalidInput);
    EXPECT_TRUE(d.joint_volumes().empty());  // nothing changed
}

TEST(JointVolume, TablesKeptAsABlobHoldTheSameVolumeToTheBit) {
    // A file opened again takes the tables from the blob kept with its binding instead of
    // bending every limb joint: read back, they deform every pose as the measured ones did.
    const test::Arm arm;
    const Binding binding = arm.bind();
    JointVolumeTable t = numbered_elbow();
    for (double& v : t.added) v *= 1e-4;  // (within the sweep's rest volume)
    t.most_added = 0.01;
    Deformer measured(arm.rig, binding), loaded(arm.rig, binding), none(arm.rig, binding);
    measured.set_joint_volumes({t});
    const std::vector<uint8_t> blob = serialize_joint_volumes(measured.joint_volumes(), rig_fingerprint(arm.rig));
    uint64_t fingerprint = 0;
    loaded.set_joint_volumes(deserialize_joint_volumes(blob.data(), blob.size(), &fingerprint));
    EXPECT_EQ(fingerprint, rig_fingerprint(arm.rig));
    std::vector<float> a(arm.mesh.size()), b(arm.mesh.size()), c(arm.mesh.size());
    for (const double degrees : {45.0, 100.0, 150.0}) {
        const auto pose = arm.pose(glm::radians(degrees));
        measured.deform(pose.data(), a.data());
        loaded.deform(pose.data(), b.data());
        none.deform(pose.data(), c.data());
        EXPECT_EQ(a, b) << degrees;
        EXPECT_NE(a, c) << degrees;  // (the tables matter in these poses)
    }
    // Damaged: a byte changed (the checksum), cut short, axes not at right angles.
    std::vector<uint8_t> changed = blob;
    changed[30] ^= 1;
    EXPECT_THROW(deserialize_joint_volumes(changed.data(), changed.size(), nullptr), CorruptData);
    EXPECT_THROW(deserialize_joint_volumes(blob.data(), blob.size() - 1, nullptr), CorruptData);
    JointVolumeTable skew = t;
    skew.e1 = glm::normalize(dvec3(0.1, 1, 0));
    const std::vector<uint8_t> skewed = serialize_joint_volumes({skew}, 0);
    EXPECT_THROW(deserialize_joint_volumes(skewed.data(), skewed.size(), nullptr), CorruptData);
}

}  // namespace
}  // namespace sd

namespace sd {
namespace {

TEST(JointVolume, AnArmWhoseMeshKeepsItsVolumeGetsNoTable) {
    // The synthetic arm's skin lies on its sweep, whose integral the controller holds: bent,
    // its open tube (cone volume from the elbow: the ends stay put or turn about it) changes
    // by less than 0.1 % of the limb's volume (0.02 % lost at 45°, up to 0.2 % gained at
    // 135°), which is not worth holding. No joint gets a table, and every pose deforms as before.
    const test::Arm arm;
    Deformer d(arm.rig, arm.bind());
    const std::vector<int32_t> tris = arm.ring_triangles();
    const double v0 = cone_volume(arm.mesh.data(), tris, dvec3(1, 0, 0));
    std::vector<float> before(arm.mesh.size()), after(arm.mesh.size());
    d.deform(arm.pose(0.6 * kPi).data(), before.data());
    EXPECT_LT(std::abs(v0 - cone_volume(before.data(), tris, dvec3(1, 0, 0))), 1e-3 * v0);
    d.set_joint_volumes(measure_joint_volumes(d, static_cast<int32_t>(tris.size() / 3), tris.data()));
    EXPECT_TRUE(d.joint_volumes().empty());
    d.deform(arm.pose(0.6 * kPi).data(), after.data());
    EXPECT_EQ(after, before);
}

TEST(JointVolume, BadTrianglesAreRefusedAndChangeNothing) {
    const test::Arm arm;
    Deformer d(arm.rig, arm.bind());
    const std::vector<int32_t> out_of_range = {0, 1, arm.vertex_count()}, negative = {0, -1, 2};
    EXPECT_THROW(measure_joint_volumes(d, 1, out_of_range.data()), InvalidInput);
    EXPECT_THROW(measure_joint_volumes(d, 1, negative.data()), InvalidInput);
    EXPECT_THROW(measure_joint_volumes(d, -1, negative.data()), InvalidInput);
    EXPECT_THROW(measure_joint_volumes(d, 1, nullptr), InvalidInput);
    EXPECT_TRUE(d.volume_enabled());
    EXPECT_EQ(d.volume_strength(), 1.0);
}

}  // namespace
}  // namespace sd

namespace sd {
namespace {

TEST(JointVolume, TheMakeHumanBodyKeepsItsVolumeWhenTheHipFlexesAndAddsNoneToALoweredArm) {
    // The product's fitting and binding on the CC0 MakeHuman male (13.4K vertices), the thigh
    // flexed 70° (between the table's rows) about axes turned off the body's side axis
    // (between its directions). The body is one closed mesh: its cone volume from any apex is
    // its volume.
    const std::string path = std::string(SWEEPDEFORM_SHARED_DATA_DIR) + "/humans/mh_male_game_engine.glb";
    if (!std::filesystem::exists(path)) GTEST_SKIP() << "../shared/data not found (" << path << "): skipped";
    const character_fit::Fitted fitted = character_fit::fit_and_bind(io::load_gltf_character(path));
    const io::Character& c = fitted.character;
    const Skeleton& s = fitted.skeleton;
    Deformer& d = *fitted.deformer;
    const int V = static_cast<int>(c.positions.size() / 3);

    const int thigh = character_fit::bone_named(c, "thigh_l"), thigh_r = character_fit::bone_named(c, "thigh_r"),
              head = character_fit::bone_named(c, "head");
    ASSERT_TRUE(thigh >= 0 && thigh_r >= 0 && head >= 0);
    const dvec3 left = glm::normalize(s.heads[thigh] - s.heads[thigh_r]);
    const dvec3 up = glm::normalize(s.heads[head] - s.heads[thigh]);
    const dvec3 front = glm::normalize(glm::cross(left, up));
    const dvec3 hip = s.heads[thigh];
    const std::vector<float> rest_pose = io::rest_pose(c);
    // Flexion (the knee forwards) about an axis turned by `tilt` (> 0: the knee goes outwards).
    const auto flexed = [&](double tilt) {
        const dvec3 axis = glm::normalize(-std::cos(tilt) * left + std::sin(tilt) * front);
        return testing::turned_pose(s, thigh, testing::turn_about(hip, axis, 70.0 * kPi / 180.0));
    };
    const double v0 = cone_volume(c.positions.data(), c.triangles, hip);
    std::vector<float> out(c.positions.size());
    const auto lost = [&](const std::vector<float>& pose) {
        d.deform(pose.data(), out.data());
        return v0 - cone_volume(out.data(), c.triangles, hip);
    };
    const double tilts[] = {-0.25, 0.35};  // inwards a little: the groin folds; outwards: it does not
    double before[2];
    before[1] = lost(flexed(tilts[1]));
    before[0] = lost(flexed(tilts[0]));
    const std::vector<float> plain = out;  // flexed inwards, without the tables
    d.deform(rest_pose.data(), out.data());
    const std::vector<float> rest = out;

    const auto t0 = std::chrono::steady_clock::now();
    d.set_joint_volumes(measure_joint_volumes(d, static_cast<int32_t>(c.triangles.size() / 3), c.triangles.data()));
    const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    double after[2];
    after[1] = lost(flexed(tilts[1]));
    after[0] = lost(flexed(tilts[0]));  // (last: `out` holds it)
    // Where the volume goes: at the hip, not down the thigh at the knee.
    const int calf = character_fit::bone_named(c, "calf_l");
    ASSERT_GE(calf, 0);
    double at_hip = 0.0, at_knee = 0.0;
    for (int v = 0; v < V; ++v) {
        const dvec3 p(c.positions[3 * v], c.positions[3 * v + 1], c.positions[3 * v + 2]);
        const double moved = glm::length(
            dvec3(out[3 * v] - plain[3 * v], out[3 * v + 1] - plain[3 * v + 1], out[3 * v + 2] - plain[3 * v + 2]));
        if (glm::length(p - hip) < 0.15) at_hip = std::max(at_hip, moved);
        if (glm::length(p - s.heads[calf]) < 0.12) at_knee = std::max(at_knee, moved);
    }
    std::printf(
        "body %.2f L; hip flexed 70 deg, %zu joints measured in %.0f ms; lost (L) inwards %.3f -> %.3f, "
        "outwards %.3f -> %.3f; skin moved by the tables at the hip %.1f mm, at the knee %.1f mm\n",
        1e3 * v0, d.joint_volumes().size(), ms, 1e3 * before[0], 1e3 * after[0], 1e3 * before[1], 1e3 * after[1],
        1e3 * at_hip, 1e3 * at_knee);
    EXPECT_GT(before[0], 0.005 * v0);  // worth holding
    // Within a third (the table adds at most 10 % of the leg's sweep; without it, all of it).
    EXPECT_LT(std::abs(after[0]), before[0] / 3.0);
    EXPECT_GT(at_hip, 0.003);
    EXPECT_LT(at_knee, 0.5 * at_hip);                        // through the controller's own keys it went to the knee
    EXPECT_LT(std::abs(before[1]), 0.001 * v0);              // nothing to hold ...
    EXPECT_LT(std::abs(after[1] - before[1]), 0.0015 * v0);  // ... and little added
    d.deform(rest_pose.data(), out.data());
    EXPECT_EQ(out, rest);

    // The arm lowered 25° towards the body (the armpit closing) takes nothing from its shoulder's
    // table (it had: the top of the shoulder swelled, the armpit's skin pressed into itself).
    const int upperarm = character_fit::bone_named(c, "upperarm_l"),
              lowerarm = character_fit::bone_named(c, "lowerarm_l");
    ASSERT_TRUE(upperarm >= 0 && lowerarm >= 0);
    const std::vector<JointVolumeTable> tables = d.joint_volumes();
    ASSERT_TRUE(
        std::any_of(tables.begin(), tables.end(), [&](const JointVolumeTable& t) { return t.child == upperarm; }));
    const dvec3 shoulder = s.heads[upperarm], arm = glm::normalize(s.heads[lowerarm] - shoulder);
    const std::vector<float> lowered =
        testing::turned_pose(s, upperarm, testing::turn_about(shoulder, glm::cross(arm, -up), 25.0 * kPi / 180.0));
    std::vector<float> with_tables(out.size()), without(out.size());
    d.deform(lowered.data(), with_tables.data());
    d.set_joint_volumes({});
    d.deform(lowered.data(), without.data());
    EXPECT_EQ(with_tables, without);
}

}  // namespace
}  // namespace sd
