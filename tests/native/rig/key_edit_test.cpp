// Key-ellipse editing (Sect. 4.2) on the synthetic arm: the joint angle of every key, the
// interpolation of corrections over it (rest pinned, monotone, clamped), the deformation
// changing only near the edited key and the edit's angle, volume control keeping a scaling
// edit, rest corrections, blobs of format version 4 (and reading versions 1 to 3), and the C ABI.
#include "rig/key_pose.h"
#include "bind/blob_io.h"
#include "bind/serialize.h"
#include "sweepdeform/sweepdeform.h"
#include "test_arm.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>

namespace sd {
namespace {

const double k150 = glm::radians(150.0);

/// `blob` framed as format `version` without the last `dropped` bytes of its payload (the
/// sections that version does not have).
std::vector<uint8_t> older_rig_blob(const std::vector<uint8_t>& blob, uint32_t version, size_t dropped) {
    std::vector<uint8_t> out(blob.begin(), blob.begin() + 16);
    uint64_t size;
    std::memcpy(&size, &blob[8], 8);
    const uint64_t payload = size - dropped;
    std::vector<uint8_t> body(blob.begin() + 16, blob.begin() + 16 + static_cast<long>(payload));
    const uint32_t crc = crc32(body.data(), body.size());
    std::memcpy(&out[4], &version, 4);
    std::memcpy(&out[8], &payload, 8);
    out.insert(out.end(), body.begin(), body.end());
    const auto* c = reinterpret_cast<const uint8_t*>(&crc);
    out.insert(out.end(), c, c + 4);
    return out;
}

double max_distance(const std::vector<float>& a, const std::vector<float>& b, double x_min = -1e9, double x_max = 1e9,
                    const std::vector<float>* rest = nullptr) {
    double d = 0;
    for (size_t i = 0; i < a.size(); i += 3) {
        const double x = rest ? (*rest)[i] : a[i];
        if (x < x_min || x > x_max) continue;
        d = std::max(d, glm::length(dvec3(a[i] - b[i], a[i + 1] - b[i + 1], a[i + 2] - b[i + 2])));
    }
    return d;
}

std::vector<float> deform(const Rig& rig, const Binding& binding, double bend, bool volume = true,
                          Deformer** keep = nullptr) {
    static std::unique_ptr<Deformer> last;
    last = std::make_unique<Deformer>(rig, binding);
    last->set_volume_preservation(volume, 1.0);
    std::vector<float> out(binding.rest_positions.size());
    test::Arm arm;
    last->deform(arm.pose(bend).data(), out.data());
    if (keep) *keep = last.get();
    return out;
}

KeyCorrection correction(double angle, dvec3 dc = dvec3(0.0), dvec3 dr = dvec3(0.0), double sa = 1.0, double sb = 1.0) {
    KeyCorrection c;
    c.angle = angle;
    c.delta_center = dc;
    c.delta_rotation = dr;
    c.scale_a = sa;
    c.scale_b = sb;
    return c;
}

TEST(KeyEdit, EveryKeyHasAJointAndItsAngleIsTheBendBetweenTheLinks) {
    const test::Arm arm;
    const Sweep& s = arm.rig.sweeps[0];
    // Keys at x = 0, 1/3, 2/3 | 1 (elbow: upper arm 0 / forearm 1) | 4/3, 5/3 | 2 (wrist: 1 / 2).
    const int elbow[7] = {1, 1, 1, 1, 1, 2, 2};
    for (int k = 0; k < 7; ++k) {
        EXPECT_EQ(s.joints[k].child, elbow[k]) << k;
        EXPECT_EQ(s.joints[k].parent, elbow[k] - 1) << k;
        EXPECT_NEAR(s.joints[k].rest_angle, 0.0, 1e-12);
    }
    SkeletonPose pose;
    pose.set(arm.rig.skeleton, arm.pose(k150).data());
    EXPECT_NEAR(joint_angle(s.joints[3], pose), k150, 1e-6);
    EXPECT_NEAR(joint_angle(s.joints[5], pose), 0.0, 1e-6);  // the wrist stays straight
    pose.set_rest(arm.rig.skeleton);
    EXPECT_EQ(joint_angle(s.joints[3], pose), s.joints[3].rest_angle);
}

TEST(KeyEdit, JointAnglesFollowTheLimbWhicheverWayItsBonesPoint) {
    // A glTF rig has no tails: importers point every bone one way (CesiumMan's all point +x,
    // whatever its limbs do). The same arm with every bone pointing +z, the way the elbow bends
    // about: the joint's angle is still the bend between the links (from head to head), so an
    // edit made at a bent elbow applies there and not at rest.
    const test::Arm straight;
    Rig rig;
    rig.skeleton = straight.rig.skeleton;
    for (int b = 0; b < rig.skeleton.bone_count(); ++b)
        rig.skeleton.tails[b] = rig.skeleton.heads[b] + dvec3(0, 0, 0.3);
    rig.add_sweep(straight.rig.sweeps[0].keys);
    const Sweep& s = rig.sweeps[0];
    SkeletonPose pose;
    pose.set(rig.skeleton, straight.pose(k150).data());
    EXPECT_NEAR(s.joints[3].rest_angle, 0.0, 1e-12);
    EXPECT_NEAR(joint_angle(s.joints[3], pose), k150, 1e-6);
    EXPECT_NEAR(joint_angle(s.joints[1], pose), k150, 1e-6);  // the upper arm's keys: the elbow too
    // The hand has no child: its link is along its bone (+z here, 90° off the forearm at rest);
    // the wrist does not bend, and its angle stays its rest angle.
    EXPECT_NEAR(joint_angle(s.joints[6], pose), s.joints[6].rest_angle, 1e-6);

    const Binding binding = straight.bind();
    Rig edited = rig;
    edited.set_key_corrections(0, 3, {correction(k150, dvec3(0, 0.02, 0))});
    EXPECT_EQ(deform(edited, binding, 0.0), deform(rig, binding, 0.0));  // rest: untouched
    EXPECT_GT(max_distance(deform(edited, binding, k150), deform(rig, binding, k150)), 0.01);
}

TEST(KeyEdit, InterpolationPinsTheRestAndClampsBeyondTheSamples) {
    const std::vector<KeyCorrection> one = {correction(k150, dvec3(0.02, -0.01, 0.03), dvec3(0, 0.2, 0), 1.3, 0.8)};
    // Rest: exactly nothing. At the sample: exactly the sample. Beyond: the same.
    EXPECT_TRUE(correction_at(one, 0.0, 0.0).is_identity());
    EXPECT_TRUE(correction_at(one, 0.0, 5e-6).is_identity());
    for (double angle : {k150, k150 + 1e-6, 3.0, M_PI}) {
        const KeyCorrectionValue v = correction_at(one, 0.0, angle);
        EXPECT_NEAR(v.delta_center.z, 0.03, 1e-15);
        EXPECT_NEAR(v.delta_rotation.y, 0.2, 1e-15);
        EXPECT_NEAR(v.scale_a, 1.3, 1e-12);
        EXPECT_NEAR(v.scale_b, 0.8, 1e-12);
    }
    // In between: monotone from 0 to the sample, smooth (a smoothstep for two samples).
    double last = 0.0, last_slope = 0.0;
    for (int i = 1; i < 150; ++i) {
        const double angle = glm::radians(double(i));
        const double v = correction_at(one, 0.0, angle).delta_center.z;
        EXPECT_GT(v, last - 1e-15);
        EXPECT_LT(v, 0.03);
        const double slope = (v - last) / glm::radians(1.0);
        EXPECT_LT(std::abs(slope - last_slope), 0.002) << i;  // no kink
        last = v;
        last_slope = slope;
    }
    EXPECT_NEAR(correction_at(one, 0.0, 0.5 * k150).delta_center.z, 0.015, 1e-12);  // symmetric
    // A muted correction is no correction.
    std::vector<KeyCorrection> muted = one;
    muted[0].muted = true;
    EXPECT_TRUE(correction_at(muted, 0.0, k150).is_identity());
}

TEST(KeyEdit, ThreeSamplesNeverOvershoot) {
    const double a90 = glm::radians(90.0);
    const std::vector<KeyCorrection> cs = {correction(a90, dvec3(0, 0, 0.05)), correction(k150, dvec3(0, 0, 0.05)),
                                           correction(3.0, dvec3(0, 0, -0.02))};
    for (int i = 0; i <= 180; ++i) {
        const double v = correction_at(cs, 0.0, glm::radians(double(i))).delta_center.z;
        EXPECT_LE(v, 0.05 + 1e-15);
        EXPECT_GE(v, -0.02 - 1e-15);
        if (i >= 90 && i <= 150) EXPECT_NEAR(v, 0.05, 1e-15);  // flat between equal samples
    }
}

TEST(KeyEdit, ACorrectionAtRestShiftsEveryPose) {
    const std::vector<KeyCorrection> at_rest = {correction(0.3, dvec3(0, 0.01, 0))};
    for (double angle : {0.0, 0.3, 1.0, k150, M_PI}) EXPECT_EQ(correction_at(at_rest, 0.3, angle).delta_center.y, 0.01);
    // With a second one at 150°, the two are joined smoothly.
    const std::vector<KeyCorrection> two = {at_rest[0], correction(k150, dvec3(0, 0.03, 0))};
    EXPECT_EQ(correction_at(two, 0.3, 0.3).delta_center.y, 0.01);
    EXPECT_EQ(correction_at(two, 0.3, k150).delta_center.y, 0.03);
    const double mid = correction_at(two, 0.3, 0.5 * (0.3 + k150)).delta_center.y;
    EXPECT_NEAR(mid, 0.02, 1e-12);
}

TEST(KeyEdit, AnEditAt150DegreesChangesOnlyThatPoseAndOnlyNearTheKey) {
    const test::Arm arm(0.1, 0.07, 97, 32);
    const Binding binding = arm.bind();
    // Turn the elbow key about its major axis (a); also push it along its minor axis (b).
    Rig turned = arm.rig, edited = arm.rig;
    turned.set_key_corrections(0, 3, {correction(k150, dvec3(0.0), dvec3(0.25, 0, 0))});
    edited.set_key_corrections(0, 3, {correction(k150, dvec3(0, 0.02, 0), dvec3(0.25, 0, 0))});
    for (bool volume : {false, true})
        for (const Rig* rig : {&turned, &edited}) {
            const bool moved = rig == &edited;
            // Rest: bit for bit the same.
            EXPECT_EQ(deform(*rig, binding, 0.0, volume), deform(arm.rig, binding, 0.0, volume));
            // 150°: the elbow region changes, the shoulder end (x < 0.3) does not: Q(t) is
            // piecewise linear, so a turn reaches the neighbouring keys only; a moved center
            // bends the cubic C(t), which decays along the sweep.
            const auto before = deform(arm.rig, binding, k150, volume), after = deform(*rig, binding, k150, volume);
            const double near = max_distance(before, after, 0.75, 1.25, &arm.mesh);
            const double far = max_distance(before, after, -1.0, 0.3, &arm.mesh);
            EXPECT_GT(near, 0.01) << volume << moved;
            const double limit = moved ? 0.05 : volume ? 0.02 : 1e-6;
            EXPECT_LT(far, limit * near) << volume << moved << " far " << far << " near " << near;
            // Far in angle: 30° gets the smoothstep's 10 % of an edit made at 150°, 90° about half.
            const auto change_at = [&](double degrees) {
                return max_distance(deform(arm.rig, binding, glm::radians(degrees), volume),
                                    deform(*rig, binding, glm::radians(degrees), volume));
            };
            EXPECT_LT(change_at(30.0), 0.15 * near) << volume << moved;
            EXPECT_LT(change_at(5.0), 0.01 * near) << volume << moved;
            EXPECT_GT(change_at(90.0), 0.3 * near) << volume << moved;
        }
}

TEST(KeyEdit, VolumeControlKeepsAScalingEdit) {
    const test::Arm arm;
    const Binding binding = arm.bind();
    Rig edited = arm.rig;
    edited.set_key_corrections(0, 3, {correction(k150, dvec3(0.0), dvec3(0.0), 1.3, 1.3)});
    Deformer* d = nullptr;
    const auto plain = deform(arm.rig, binding, k150, true);
    const auto scaled = deform(edited, binding, k150, true, &d);
    const Sweep& s = edited.sweeps[0];
    EXPECT_EQ(s.corrected_rest_volume, s.rest_volume);  // no rest correction: V0 unchanged
    // The target is V0 plus what the scaling adds in this pose: the volume grew, and the
    // controller met the target (within its tolerance) instead of shrinking the edit away.
    EXPECT_GT(d->volume_after[0], 1.005 * s.rest_volume);
    // The elbow ring (x = 1 at rest) is wider than without the edit by most of the 30 %.
    double r_plain = 0, r_scaled = 0;
    for (int v = 0; v < arm.vertex_count(); ++v)
        if (std::abs(arm.mesh[3 * v] - 1.0) < 1e-6) {
            const dvec3 elbow(1, 0, 0);
            r_plain = std::max(r_plain, glm::length(dvec3(plain[3 * v], plain[3 * v + 1], plain[3 * v + 2]) - elbow));
            r_scaled =
                std::max(r_scaled, glm::length(dvec3(scaled[3 * v], scaled[3 * v + 1], scaled[3 * v + 2]) - elbow));
        }
    EXPECT_GT(r_scaled / r_plain, 1.2);
}

TEST(KeyEdit, ARestCorrectionDeformsTheRestPoseAndResetsV0) {
    const test::Arm arm;
    const Binding binding = arm.bind();
    Rig edited = arm.rig;
    edited.set_key_corrections(0, 3, {correction(0.0, dvec3(0, 0.03, 0), dvec3(0.0), 1.2, 1.0)});
    const Sweep& s = edited.sweeps[0];
    EXPECT_NE(s.corrected_rest_volume, s.rest_volume);
    Deformer* d = nullptr;
    const auto rest = deform(edited, binding, 0.0, true, &d);
    EXPECT_EQ(d->volume_iterations[0], 0);                           // the corrected rest is the controller's rest
    EXPECT_GT(max_distance(rest, arm.mesh, 0.9, 1.1), 0.02);         // the elbow moved at rest
    EXPECT_LT(max_distance(rest, arm.mesh, -1.0, 0.2), 0.1 * 0.03);  // the shoulder hardly
    // And every other pose is shifted too.
    EXPECT_GT(max_distance(deform(edited, binding, k150), deform(arm.rig, binding, k150), 0.8, 1.2), 0.02);
}

TEST(KeyEdit, InvalidCorrectionsAreRefusedAndChangeNothing) {
    test::Arm arm;
    arm.rig.set_key_corrections(0, 3, {correction(1.0, dvec3(0.01, 0, 0))});
    const auto before = serialize_rig(arm.rig);
    const std::vector<KeyCorrection> bad[] = {
        {correction(-0.1)},
        {correction(4.0)},
        {correction(NAN)},
        {correction(1.0, dvec3(2.0, 0, 0))},
        {correction(1.0, dvec3(0.0), dvec3(0, 0, 1.7))},
        {correction(1.0, dvec3(0.0), dvec3(0.0), 0.05)},
        {correction(1.0, dvec3(0.0), dvec3(0.0), 1.0, 11.0)},
        {correction(1.0, dvec3(0.0), dvec3(0.0), INFINITY)},
        // At rest, the elbow key moved onto its neighbour (x = 2/3).
        {correction(0.0, dvec3(0, 0, -1.0 / 3.0))},
    };
    for (const auto& list : bad) EXPECT_THROW(arm.rig.set_key_corrections(0, 3, list), InvalidInput);
    EXPECT_THROW(arm.rig.set_key_corrections(0, 7, {}), InvalidInput);
    EXPECT_THROW(arm.rig.set_corrections({{0, 3, correction(1.0)}, {1, 0, correction(1.0)}}), InvalidInput);
    EXPECT_EQ(serialize_rig(arm.rig), before);
}

TEST(KeyEdit, BlobsKeepCorrectionsButNotInTheFingerprint) {
    test::Arm arm;
    const uint64_t plain = rig_fingerprint(arm.rig);
    const auto v1_like = serialize_rig(arm.rig);
    KeyCorrection muted = correction(2.0, dvec3(0.0), dvec3(0.1, 0, 0));
    muted.muted = true;
    arm.rig.set_corrections({{0, 3, correction(k150, dvec3(0.01, 0.02, 0.03), dvec3(0.1, -0.2, 0.05), 1.1, 0.9)},
                             {0, 3, muted},
                             {0, 5, correction(0.0, dvec3(0, 0, 0.01))}});
    EXPECT_EQ(rig_fingerprint(arm.rig), plain);
    const auto blob = serialize_rig(arm.rig);
    const Rig back = deserialize_rig(blob.data(), blob.size());
    EXPECT_EQ(serialize_rig(back), blob);
    ASSERT_EQ(back.corrections().size(), 3u);
    EXPECT_TRUE(back.sweeps[0].keys[3].corrections[0].muted);  // sorted: 2.0 before 150°
    EXPECT_EQ(back.sweeps[0].corrected_rest_volume, arm.rig.sweeps[0].corrected_rest_volume);
    // A binding made before the edit still fits.
    EXPECT_NO_THROW(Deformer(back, test::Arm().bind()));

    // Version 1 (the payload without the corrections section): still read, no corrections.
    const size_t K = 7;
    // one int32 0 per key ellipse (no corrections), one double per key (the twist spreads),
    // three per key (the twist directions)
    const std::vector<uint8_t> v1 = older_rig_blob(v1_like, 1, (4 + 8 + 24) * K);
    const Rig old = deserialize_rig(v1.data(), v1.size());
    EXPECT_TRUE(old.corrections().empty());
    EXPECT_EQ(rig_fingerprint(old), plain);
    // A version 5 blob is refused.
    std::vector<uint8_t> v5 = blob;
    v5[4] = 5;
    EXPECT_THROW(deserialize_rig(v5.data(), v5.size()), CorruptData);
}

/// The arm's rig with `keys` for its own (in `rig`), as a blob that reads back (`back`) to
/// itself, with the arm's fingerprint: what the later sections hold leaves a binding valid.
std::vector<uint8_t> arm_blob_with(const test::Arm& arm, const std::vector<KeyEllipse>& keys, Rig& rig, Rig& back) {
    rig.skeleton = arm.rig.skeleton;
    rig.add_sweep(keys);
    EXPECT_EQ(rig_fingerprint(rig), rig_fingerprint(arm.rig));
    const std::vector<uint8_t> blob = serialize_rig(rig);
    back = deserialize_rig(blob.data(), blob.size());
    EXPECT_EQ(serialize_rig(back), blob);
    return blob;
}

TEST(KeyEdit, BlobsKeepTheTwistSpreadButNotInTheFingerprint) {
    // Version 3 keeps each key's twist spread (the fitting's, from the mesh's rings); a
    // version 2 blob, which has none, reads with the default, and the spread leaves the
    // binding's fingerprint alone (the rest pose does not depend on it).
    const test::Arm arm;
    std::vector<KeyEllipse> keys = arm.rig.sweeps[0].keys;
    keys.back().twist_spread = 1.25;
    Rig rig, back;
    const std::vector<uint8_t> blob = arm_blob_with(arm, keys, rig, back);
    EXPECT_EQ(back.sweeps[0].keys.back().twist_spread, 1.25);
    const std::vector<uint8_t> v2 = older_rig_blob(blob, 2, (8 + 24) * keys.size());
    const Rig old = deserialize_rig(v2.data(), v2.size());
    EXPECT_EQ(old.sweeps[0].keys.back().twist_spread, kDefaultTwistSpread);
    EXPECT_EQ(serialize_rig(old), serialize_rig(arm.rig));
    // Out of [1, 2]: refused like any other bad key.
    for (double bad : {0.5, 2.5, std::nan("")}) {
        keys.back().twist_spread = bad;
        EXPECT_THROW(rig.add_sweep(keys), InvalidInput) << bad;
    }
}

TEST(KeyEdit, BlobsKeepTheTwistDirectionButNotInTheFingerprint) {
    // Version 4 keeps each joint key's twist direction (the fitting's: the neck's line at the
    // neck's joint); a version 3 blob, which has none, reads with every twist about the key's
    // normal, as it deformed when it was saved; the fingerprint does not change.
    const test::Arm arm;
    std::vector<KeyEllipse> keys = arm.rig.sweeps[0].keys;
    ASSERT_TRUE(keys[3].is_joint_key());
    keys[3].twist_direction = glm::normalize(dvec3(0.1, 0.0, 1.0));
    Rig rig, back;
    const std::vector<uint8_t> blob = arm_blob_with(arm, keys, rig, back);
    EXPECT_EQ(back.sweeps[0].keys[3].twist_direction, keys[3].twist_direction);
    EXPECT_EQ(back.sweeps[0].keys[3].twist_axis(), keys[3].twist_direction);
    const std::vector<uint8_t> v3 = older_rig_blob(blob, 3, 24 * keys.size());
    const Rig old = deserialize_rig(v3.data(), v3.size());
    EXPECT_EQ(old.sweeps[0].keys[3].twist_direction, dvec3(0.0));
    EXPECT_EQ(old.sweeps[0].keys[3].twist_axis(), old.sweeps[0].keys[3].normal());
    EXPECT_EQ(serialize_rig(old), serialize_rig(arm.rig));
    // Neither zero nor a unit vector: refused like any other bad key.
    for (const dvec3& bad : {dvec3(0.5, 0.0, 0.0), dvec3(std::nan(""), 0.0, 1.0), dvec3(0.0, 0.0, 1e300)}) {
        keys[3].twist_direction = bad;
        EXPECT_THROW(rig.add_sweep(keys), InvalidInput);
    }
}

// ---- the C ABI --------------------------------------------------------------------------

struct AbiRig {
    sd_rig* rig = nullptr;
    test::Arm arm;
    AbiRig() {
        const std::vector<uint8_t> blob = serialize_rig(arm.rig);
        EXPECT_EQ(sd_rig_deserialize(blob.data(), static_cast<int64_t>(blob.size()), &rig), SD_OK);
    }
    ~AbiRig() { sd_rig_destroy(rig); }
};

TEST(KeyEditAbi, SetReplaceMuteRemoveAndList) {
    AbiRig r;
    const float v150[8] = {0.01f, 0.02f, 0.03f, 0.1f, 0, 0, 1.2f, 0.9f};
    const float v90[8] = {0, 0, 0.01f, 0, 0, 0, 1, 1};
    int32_t index = -1;
    ASSERT_EQ(sd_rig_set_key_correction(r.rig, 0, 3, static_cast<float>(k150), v150, 0, &index), SD_OK);
    EXPECT_EQ(index, 0);
    ASSERT_EQ(sd_rig_set_key_correction(r.rig, 0, 3, 1.5708f, v90, 0, &index), SD_OK);
    EXPECT_EQ(index, 0);  // sorted by angle
    EXPECT_EQ(sd_rig_key_correction_count(r.rig, 0, 3), 2);
    // Replace at (almost) the same angle.
    float v150b[8];
    std::memcpy(v150b, v150, sizeof v150);
    v150b[2] = 0.05f;
    ASSERT_EQ(sd_rig_set_key_correction(r.rig, 0, 3, static_cast<float>(k150) + 5e-4f, v150b, 0, &index), SD_OK);
    EXPECT_EQ(index, 1);
    EXPECT_EQ(sd_rig_key_correction_count(r.rig, 0, 3), 2);
    float angles[2], values[16];
    int32_t muted[2];
    ASSERT_EQ(sd_rig_get_key_corrections(r.rig, 0, 3, 2, angles, values, muted), SD_OK);
    EXPECT_FLOAT_EQ(values[8 + 2], 0.05f);
    EXPECT_FLOAT_EQ(values[8 + 6], 1.2f);
    EXPECT_EQ(muted[1], 0);
    EXPECT_EQ(sd_rig_get_key_corrections(r.rig, 0, 3, 3, angles, values, muted), SD_ERR_MISMATCH);

    // The interpolated value, and the key ellipse it gives.
    float at[8];
    ASSERT_EQ(sd_rig_key_correction_at(r.rig, 0, 3, angles[1], at), SD_OK);
    EXPECT_FLOAT_EQ(at[2], 0.05f);
    ASSERT_EQ(sd_rig_key_correction_at(r.rig, 0, 3, 0.0f, at), SD_OK);
    EXPECT_EQ(at[2], 0.0f);
    EXPECT_EQ(at[6], 1.0f);

    ASSERT_EQ(sd_rig_mute_key_correction(r.rig, 0, 3, 1, 1), SD_OK);
    ASSERT_EQ(sd_rig_get_key_corrections(r.rig, 0, 3, 2, nullptr, nullptr, muted), SD_OK);
    EXPECT_EQ(muted[1], 1);
    ASSERT_EQ(sd_rig_key_correction_at(r.rig, 0, 3, angles[1], at), SD_OK);
    EXPECT_FLOAT_EQ(at[2], 0.01f);  // only the 90° one is left, clamped beyond it

    // Whole-rig list.
    ASSERT_EQ(sd_rig_set_key_correction(r.rig, 0, 5, 0.0f, v90, 0, nullptr), SD_OK);
    ASSERT_EQ(sd_rig_correction_count(r.rig), 3);
    int32_t sweeps[3], keys[3], all_muted[3];
    float all_angles[3], all_values[24];
    ASSERT_EQ(sd_rig_get_corrections(r.rig, 3, sweeps, keys, all_angles, all_values, all_muted), SD_OK);
    EXPECT_EQ(keys[0], 3);
    EXPECT_EQ(keys[2], 5);

    ASSERT_EQ(sd_rig_remove_key_correction(r.rig, 0, 3, 0), SD_OK);
    EXPECT_EQ(sd_rig_key_correction_count(r.rig, 0, 3), 1);
    EXPECT_EQ(sd_rig_remove_key_correction(r.rig, 0, 3, 1), SD_ERR_INVALID_ARGUMENT);
    EXPECT_EQ(sd_rig_key_correction_count(r.rig, 0, 9), -1);
    EXPECT_NE(std::string(sd_last_error()), "");

    // Bulk replace: all or nothing; count 0 clears.
    const float bad[8] = {0, 0, 0, 0, 0, 0, 50.0f, 1};
    const int32_t s2[2] = {0, 0}, k2[2] = {1, 2};
    const float a2[2] = {1.0f, 1.0f};
    float two[16];
    std::memcpy(two, v90, sizeof v90);
    std::memcpy(two + 8, bad, sizeof bad);
    EXPECT_EQ(sd_rig_set_corrections(r.rig, 2, s2, k2, a2, two, nullptr), SD_ERR_INVALID_ARGUMENT);
    EXPECT_NE(std::string(sd_last_error()).find("scales"), std::string::npos) << sd_last_error();
    EXPECT_EQ(sd_rig_correction_count(r.rig), 2);
    EXPECT_EQ(sd_rig_set_corrections(r.rig, 0, nullptr, nullptr, nullptr, nullptr, nullptr), SD_OK);
    EXPECT_EQ(sd_rig_correction_count(r.rig), 0);
}

TEST(KeyEditAbi, JointAnglesPosedKeysAndThePosedSweep) {
    AbiRig r;
    const auto pose = r.arm.pose(k150);
    int32_t parent = -2, child = -2;
    float rest = -1, angle = -1;
    ASSERT_EQ(sd_rig_key_joint(r.rig, 0, 4, &parent, &child, &rest), SD_OK);
    EXPECT_EQ(parent, 0);
    EXPECT_EQ(child, 1);
    EXPECT_EQ(rest, 0.0f);
    ASSERT_EQ(sd_rig_key_joint_angle(r.rig, 0, 3, 3, pose.data(), &angle), SD_OK);
    EXPECT_NEAR(angle, k150, 1e-5);
    ASSERT_EQ(sd_rig_key_joint_angle(r.rig, 0, 3, 3, nullptr, &angle), SD_OK);
    EXPECT_EQ(angle, 0.0f);
    EXPECT_EQ(sd_rig_key_joint_angle(r.rig, 0, 3, 2, pose.data(), &angle), SD_ERR_INVALID_ARGUMENT);

    // A correction at 150°: the posed key moves by R dc, turns by dr, scales.
    const float v[8] = {0, 0.02f, 0, 0, 0, 0.3f, 1.5f, 1.0f};
    ASSERT_EQ(sd_rig_set_key_correction(r.rig, 0, 3, static_cast<float>(k150), v, 0, nullptr), SD_OK);
    float c0[21], c1[21], q0[28], q1[28], ab0[14], ab1[14], angles[7];
    ASSERT_EQ(sd_rig_pose_keys(r.rig, 0, 3, pose.data(), 0, 7, c0, q0, ab0, angles), SD_OK);
    ASSERT_EQ(sd_rig_pose_keys(r.rig, 0, 3, pose.data(), 1, 7, c1, q1, ab1, nullptr), SD_OK);
    EXPECT_NEAR(angles[3], k150, 1e-5);
    const dquat qk(q0[12], q0[13], q0[14], q0[15]);
    const dvec3 moved = dvec3(c1[9], c1[10], c1[11]) - dvec3(c0[9], c0[10], c0[11]);
    EXPECT_NEAR(glm::length(moved - glm::mat3_cast(qk) * dvec3(0, 0.02, 0)), 0.0, 1e-6);
    EXPECT_NEAR(ab1[6], 1.5 * ab0[6], 1e-6);
    const dquat turned = glm::conjugate(qk) * dquat(q1[12], q1[13], q1[14], q1[15]);
    EXPECT_NEAR(2.0 * std::acos(std::min(1.0, std::abs(turned.w))), 0.3, 1e-5);
    for (int i = 0; i < 9; ++i) EXPECT_EQ(c0[i], c1[i]);  // other keys untouched
    EXPECT_EQ(sd_rig_pose_keys(r.rig, 0, 3, pose.data(), 1, 6, c1, q1, ab1, nullptr), SD_ERR_MISMATCH);

    // The posed sweep passes through the corrected keys (u = k/6 is key k).
    const float u[2] = {0.5f, 0.0f};
    float centers[6], rotations[18], half_axes[4];
    ASSERT_EQ(sd_rig_evaluate_posed_sweep(r.rig, 0, 3, pose.data(), 2, u, centers, rotations, half_axes), SD_OK);
    for (int i = 0; i < 3; ++i) EXPECT_NEAR(centers[i], c1[9 + i], 1e-6);
    EXPECT_NEAR(half_axes[0], ab1[6], 1e-6);
    const float bad_u = 1.5f;
    EXPECT_EQ(sd_rig_evaluate_posed_sweep(r.rig, 0, 3, pose.data(), 1, &bad_u, centers, nullptr, nullptr),
              SD_ERR_INVALID_ARGUMENT);
}

TEST(KeyEditAbi, ThePosedSweepOfATwistedLimbIsTheDeformersTrajectory) {
    // The overlay draws the trajectory the skin follows: with the arm's keys 2 cm off the bone
    // and the hand twisted by 180 degrees, every forearm center between keys stays 2 cm from
    // the bone (twisted_trajectory.h); the cubic through the turned key centers strayed by 1.3 mm.
    test::Arm arm;
    std::vector<KeyEllipse> keys = arm.rig.sweeps[0].keys;
    for (KeyEllipse& e : keys) e.center.y = 0.02;
    Rig offset;
    offset.skeleton = arm.rig.skeleton;
    offset.add_sweep(keys);
    const std::vector<uint8_t> blob = serialize_rig(offset);
    sd_rig* rig = nullptr;
    ASSERT_EQ(sd_rig_deserialize(blob.data(), static_cast<int64_t>(blob.size()), &rig), SD_OK);
    const auto pose = arm.pose(0.0, 3.14159265358979323846);
    std::vector<float> u, centers;
    for (int i = 0; i <= 60; ++i) u.push_back(0.5f + 0.5f * static_cast<float>(i) / 60.0f);  // the forearm
    centers.resize(3 * u.size());
    ASSERT_EQ(sd_rig_evaluate_posed_sweep(rig, 0, 3, pose.data(), static_cast<int32_t>(u.size()), u.data(),
                                          centers.data(), nullptr, nullptr),
              SD_OK);
    double worst = 0.0;
    for (size_t i = 0; i < u.size(); ++i)
        worst = std::max(worst, std::abs(std::hypot(centers[3 * i + 1], centers[3 * i + 2]) - 0.02));
    EXPECT_LT(worst, 2.5e-5);  // 1.6e-5 (the last span turns 100 degrees); the paper's cubic: 1.3e-3
    sd_rig_destroy(rig);
}

TEST(KeyEditAbi, DeformerTakesCorrectionsLikeARigMadeWithThem) {
    AbiRig r;
    const Binding b = r.arm.bind();
    const std::vector<uint8_t> bb = serialize_binding(b);
    sd_binding* binding = nullptr;
    ASSERT_EQ(sd_binding_deserialize(bb.data(), static_cast<int64_t>(bb.size()), &binding), SD_OK);
    sd_deformer *plain = nullptr, *live = nullptr, *made = nullptr;
    ASSERT_EQ(sd_deformer_create(r.rig, binding, &plain), SD_OK);
    ASSERT_EQ(sd_deformer_create(r.rig, binding, &live), SD_OK);
    const int32_t sweeps[2] = {0, 0}, keys[2] = {3, 4};
    const float angles[2] = {static_cast<float>(k150), 0.0f};
    const float values[16] = {0, 0.02f, 0, 0.2f, 0, 0, 1.2f, 1.1f, 0, 0, 0.005f, 0, 0, 0, 1, 1};
    ASSERT_EQ(sd_deformer_set_rig_corrections(live, 2, sweeps, keys, angles, values, nullptr), SD_OK);
    ASSERT_EQ(sd_rig_set_corrections(r.rig, 2, sweeps, keys, angles, values, nullptr), SD_OK);
    ASSERT_EQ(sd_deformer_create(r.rig, binding, &made), SD_OK);  // the fingerprint still fits
    const int V = r.arm.vertex_count();
    std::vector<float> p(3 * V), l(3 * V), m(3 * V);
    for (double bend : {0.0, 1.0, k150}) {
        const auto pose = r.arm.pose(bend);
        ASSERT_EQ(sd_deform(plain, 3, pose.data(), V, p.data()), SD_OK);
        ASSERT_EQ(sd_deform(live, 3, pose.data(), V, l.data()), SD_OK);
        ASSERT_EQ(sd_deform(made, 3, pose.data(), V, m.data()), SD_OK);
        EXPECT_EQ(l, m) << bend;
        EXPECT_NE(l, p) << bend;  // the rest correction of key 4 shifts every pose
    }
    double rest_v0 = 0, rest[1], before[1], after[1];
    ASSERT_EQ(sd_rig_sweep_rest_volume(r.rig, 0, &rest_v0), SD_OK);
    ASSERT_EQ(sd_deformer_get_volumes(live, 1, rest, before, after), SD_OK);
    EXPECT_NE(rest[0], rest_v0);  // V0 of the corrected rest pose
    // Invalid: refused, the deformer keeps its corrections.
    const float bad[8] = {0, 0, 0, 0, 0, 0, 1, 0.01f};
    EXPECT_EQ(sd_deformer_set_rig_corrections(live, 1, sweeps, keys, angles, bad, nullptr), SD_ERR_INVALID_ARGUMENT);
    ASSERT_EQ(sd_deform(live, 3, r.arm.pose(k150).data(), V, l.data()), SD_OK);
    EXPECT_EQ(l, m);
    sd_deformer_destroy(plain);
    sd_deformer_destroy(live);
    sd_deformer_destroy(made);
    sd_binding_destroy(binding);
}

}  // namespace
}  // namespace sd
