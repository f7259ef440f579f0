// The C ABI as a caller sees it (through libsweepdeform.so only): every invalid input is an
// error code plus a message and changes nothing; blobs round-trip; corrupt blobs are refused.
#include "sweepdeform/sweepdeform.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <limits>
#include <random>
#include <string>
#include <vector>

namespace {

const float kNaN = std::numeric_limits<float>::quiet_NaN();

/// The synthetic arm of test_arm.h, built through the ABI: 3 bones along +x, 7 keys (the first
/// key's major half-axis `first_a`: another value makes another rig).
struct AbiArm {
    std::vector<int32_t> parents = {-1, 0, 1};
    std::vector<float> rest, heads = {0, 0, 0, 1, 0, 0, 2, 0, 0}, tails = {1, 0, 0, 2, 0, 0, 2.3f, 0, 0};
    std::vector<float> centers, orientations, half_axes, fractions;
    std::vector<int32_t> bones = {0, 0, 0, 1, 1, 1, 2}, joint_parents = {-1, -1, -1, 0, -1, -1, 1};
    std::vector<float> mesh;
    sd_rig* rig = nullptr;

    explicit AbiArm(float first_a = 0.1f) {
        for (int b = 0; b < 3; ++b) {
            float m[16] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, heads[3 * b], 0, 0, 1};
            rest.insert(rest.end(), m, m + 16);
        }
        // Rotation with columns (y, z, x): the quaternion (w,x,y,z) = (0.5, 0.5, 0.5, 0.5).
        for (int k = 0; k < 7; ++k) {
            centers.insert(centers.end(), {k / 3.0f, 0, 0});
            orientations.insert(orientations.end(), {0.5f, 0.5f, 0.5f, 0.5f});
            half_axes.insert(half_axes.end(), {0.1f, 0.07f});
            fractions.insert(fractions.end(), {0.5f, k == 6 ? 1.0f : 0.5f});
        }
        for (int r = 0; r < 21; ++r)
            for (int s = 0; s < 16; ++s) {
                const double th = 2 * M_PI * s / 16;
                mesh.insert(mesh.end(), {r / 10.0f, float(0.1 * std::cos(th)), float(0.07 * std::sin(th))});
            }
        half_axes[0] = first_a;
        EXPECT_EQ(sd_rig_create(3, parents.data(), rest.data(), heads.data(), tails.data(), &rig), SD_OK);
        EXPECT_EQ(add_sweep(), SD_OK) << sd_last_error();
    }
    ~AbiArm() { sd_rig_destroy(rig); }
    sd_status add_sweep() {
        return sd_rig_add_sweep(rig, 7, centers.data(), orientations.data(), half_axes.data(), bones.data(),
                                joint_parents.data(), fractions.data(), nullptr);
    }
    int vertex_count() const { return static_cast<int>(mesh.size() / 3); }
    sd_status bind(sd_binding** out) const {
        std::vector<int32_t> ids(vertex_count(), 0);
        std::vector<float> w(vertex_count(), 1.0f);
        return sd_bind(rig, vertex_count(), mesh.data(), 1, ids.data(), w.data(), 0, nullptr, nullptr, out);
    }
};

void expect_error(sd_status status, sd_status expected, const char* what) {
    EXPECT_EQ(status, expected) << what;
    EXPECT_GT(std::strlen(sd_last_error()), 10u) << what << ": the message explains the error";
}

TEST(CApi, ReportsItsVersion) {
    EXPECT_EQ(sd_abi_version(), SD_ABI_VERSION);
    EXPECT_STREQ(sd_library_version(), "0.1.0");
}

TEST(CApi, InvalidSkeletonsAreRefused) {
    AbiArm arm;
    sd_rig* rig = nullptr;
    const auto create = [&](int n, const int32_t* parents, const float* rest, const float* heads, const float* tails) {
        return sd_rig_create(n, parents, rest, heads, tails, &rig);
    };
    expect_error(create(0, arm.parents.data(), arm.rest.data(), arm.heads.data(), arm.tails.data()),
                 SD_ERR_INVALID_ARGUMENT, "zero bones");
    expect_error(create(3, nullptr, arm.rest.data(), arm.heads.data(), arm.tails.data()), SD_ERR_INVALID_ARGUMENT,
                 "NULL parents");
    std::vector<int32_t> bad_parents = {-1, 2, 1};
    expect_error(create(3, bad_parents.data(), arm.rest.data(), arm.heads.data(), arm.tails.data()),
                 SD_ERR_INVALID_ARGUMENT, "parent cycle");
    bad_parents = {-1, 0, 3};
    expect_error(create(3, bad_parents.data(), arm.rest.data(), arm.heads.data(), arm.tails.data()),
                 SD_ERR_INVALID_ARGUMENT, "parent out of range");
    std::vector<float> rest = arm.rest;
    rest[5] = kNaN;
    expect_error(create(3, arm.parents.data(), rest.data(), arm.heads.data(), arm.tails.data()),
                 SD_ERR_INVALID_ARGUMENT, "NaN rest");
    rest = arm.rest;
    rest[0] = rest[5] = rest[10] = 0;  // zero scale
    expect_error(create(3, arm.parents.data(), rest.data(), arm.heads.data(), arm.tails.data()),
                 SD_ERR_INVALID_ARGUMENT, "degenerate rest");
    std::vector<float> tails = arm.tails;
    tails[0] = 0;  // zero-length bone
    expect_error(create(3, arm.parents.data(), arm.rest.data(), arm.heads.data(), tails.data()),
                 SD_ERR_INVALID_ARGUMENT, "zero length");
    EXPECT_EQ(rig, nullptr) << "no handle is returned on failure";
    expect_error(sd_rig_create(3, arm.parents.data(), arm.rest.data(), arm.heads.data(), arm.tails.data(), nullptr),
                 SD_ERR_INVALID_ARGUMENT, "NULL out pointer");
    sd_rig_destroy(rig);
}

TEST(CApi, InvalidKeyEllipsesAreRefusedAndChangeNothing) {
    AbiArm arm;
    const auto check = [&](const char* what, auto mutate) {
        AbiArm a;
        mutate(a);
        expect_error(a.add_sweep(), SD_ERR_INVALID_ARGUMENT, what);
        EXPECT_EQ(sd_rig_sweep_count(a.rig), 1) << what << ": the rig is unchanged";
    };
    check("non-unit quaternion", [](AbiArm& a) { a.orientations[4] = 0.9f; });
    check("zero half-axis", [](AbiArm& a) { a.half_axes[2] = 0.0f; });
    check("negative half-axis", [](AbiArm& a) { a.half_axes[3] = -0.1f; });
    check("NaN center", [](AbiArm& a) { a.centers[4] = kNaN; });
    check("infinite half-axis", [](AbiArm& a) { a.half_axes[0] = INFINITY; });
    check("bone out of range", [](AbiArm& a) { a.bones[2] = 3; });
    check("joint parent out of range", [](AbiArm& a) { a.joint_parents[3] = -2; });
    check("coincident centers", [](AbiArm& a) { a.centers[3] = 0.0f; });
    check("fraction above 1", [](AbiArm& a) { a.fractions[0] = 1.5f; });
    check("normal against the sweep", [](AbiArm& a) {
        for (int k = 0; k < 7; ++k) a.centers[3 * k] = -a.centers[3 * k];
    });
    expect_error(sd_rig_add_sweep(arm.rig, 1, arm.centers.data(), arm.orientations.data(), arm.half_axes.data(),
                                  arm.bones.data(), arm.joint_parents.data(), arm.fractions.data(), nullptr),
                 SD_ERR_INVALID_ARGUMENT, "one key");
    expect_error(sd_rig_add_sweep(nullptr, 7, arm.centers.data(), arm.orientations.data(), arm.half_axes.data(),
                                  arm.bones.data(), arm.joint_parents.data(), arm.fractions.data(), nullptr),
                 SD_ERR_INVALID_ARGUMENT, "NULL rig");
    EXPECT_EQ(sd_rig_key_count(arm.rig, 5), -1);
}

TEST(CApi, InvalidBindingInputsAreRefused) {
    AbiArm arm;
    const int V = arm.vertex_count();
    std::vector<int32_t> ids(V, 0);
    std::vector<float> w(V, 1.0f);
    sd_binding* b = nullptr;
    std::vector<float> mesh = arm.mesh;
    mesh[7] = kNaN;
    expect_error(sd_bind(arm.rig, V, mesh.data(), 1, ids.data(), w.data(), 0, nullptr, nullptr, &b),
                 SD_ERR_INVALID_ARGUMENT, "NaN vertex");
    ids[3] = 1;
    expect_error(sd_bind(arm.rig, V, arm.mesh.data(), 1, ids.data(), w.data(), 0, nullptr, nullptr, &b),
                 SD_ERR_INVALID_ARGUMENT, "sweep out of range");
    ids[3] = 0;
    w[4] = -1.0f;
    expect_error(sd_bind(arm.rig, V, arm.mesh.data(), 1, ids.data(), w.data(), 0, nullptr, nullptr, &b),
                 SD_ERR_INVALID_ARGUMENT, "negative weight");
    w[4] = 0.0f;
    expect_error(sd_bind(arm.rig, V, arm.mesh.data(), 1, ids.data(), w.data(), 0, nullptr, nullptr, &b),
                 SD_ERR_INVALID_ARGUMENT, "no weight");
    w[4] = 1.0f;
    std::vector<int32_t> bone_ids(V, 7);
    expect_error(sd_bind(arm.rig, V, arm.mesh.data(), 1, ids.data(), w.data(), 1, bone_ids.data(), w.data(), &b),
                 SD_ERR_INVALID_ARGUMENT, "bone out of range");
    expect_error(sd_bind(arm.rig, 0, arm.mesh.data(), 1, ids.data(), w.data(), 0, nullptr, nullptr, &b),
                 SD_ERR_INVALID_ARGUMENT, "zero vertices");
    expect_error(sd_bind(arm.rig, V, arm.mesh.data(), 1, nullptr, w.data(), 0, nullptr, nullptr, &b),
                 SD_ERR_INVALID_ARGUMENT, "NULL ids");
    EXPECT_EQ(b, nullptr);
}

TEST(CApi, InvalidPosesAreRefusedAndLeaveTheOutputAlone) {
    AbiArm arm;
    sd_binding* b = nullptr;
    ASSERT_EQ(arm.bind(&b), SD_OK) << sd_last_error();
    sd_deformer* d = nullptr;
    ASSERT_EQ(sd_deformer_create(arm.rig, b, &d), SD_OK) << sd_last_error();
    const int V = arm.vertex_count();
    std::vector<float> out(3 * V, 42.0f), pose = arm.rest;
    pose[13] = kNaN;
    expect_error(sd_deform(d, 3, pose.data(), V, out.data()), SD_ERR_INVALID_ARGUMENT, "NaN pose");
    pose = arm.rest;
    pose[16] = 1e30f;
    expect_error(sd_deform(d, 3, pose.data(), V, out.data()), SD_ERR_INVALID_ARGUMENT, "enormous pose");
    pose = arm.rest;
    pose[16] = pose[21] = pose[26] = 0.0f;
    expect_error(sd_deform(d, 3, pose.data(), V, out.data()), SD_ERR_INVALID_ARGUMENT, "zero-scale pose");
    expect_error(sd_deform(d, 2, arm.rest.data(), V, out.data()), SD_ERR_MISMATCH, "bone count");
    expect_error(sd_deform(d, 3, arm.rest.data(), V - 1, out.data()), SD_ERR_MISMATCH, "vertex count");
    expect_error(sd_deformer_set_volume_preservation(d, 1, 1.5f), SD_ERR_INVALID_ARGUMENT, "strength");
    for (float x : out) ASSERT_EQ(x, 42.0f) << "output touched by a failed call";
    ASSERT_EQ(sd_deform(d, 3, arm.rest.data(), V, out.data()), SD_OK);
    for (int i = 0; i < 3 * V; ++i) ASSERT_NEAR(out[i], arm.mesh[i], 1e-6);
    // sd_deform_frames: the same checks, both outputs left alone; at rest J is the identity.
    std::vector<float> pos(3 * V, 42.0f), frames(9 * V, 42.0f);
    pose = arm.rest;
    pose[13] = kNaN;
    expect_error(sd_deform_frames(d, 3, pose.data(), V, pos.data(), frames.data()), SD_ERR_INVALID_ARGUMENT,
                 "NaN pose");
    expect_error(sd_deform_frames(d, 2, arm.rest.data(), V, pos.data(), frames.data()), SD_ERR_MISMATCH, "bone count");
    expect_error(sd_deform_frames(d, 3, arm.rest.data(), V - 1, pos.data(), frames.data()), SD_ERR_MISMATCH,
                 "vertex count");
    expect_error(sd_deform_frames(d, 3, arm.rest.data(), V, pos.data(), nullptr), SD_ERR_INVALID_ARGUMENT,
                 "NULL frames");
    for (float x : pos) ASSERT_EQ(x, 42.0f) << "output touched by a failed call";
    for (float x : frames) ASSERT_EQ(x, 42.0f) << "output touched by a failed call";
    ASSERT_EQ(sd_deform_frames(d, 3, arm.rest.data(), V, pos.data(), frames.data()), SD_OK) << sd_last_error();
    EXPECT_EQ(pos, out);
    for (int r = 0; r < 3; ++r)  // block r: row r of every vertex's J
        for (int v = 0; v < V; ++v)
            for (int c = 0; c < 3; ++c) ASSERT_NEAR(frames[3 * (r * V + v) + c], r == c ? 1.0f : 0.0f, 1e-6f);
    // sd_deform_displaced, the forearm turned 90° about z at the elbow: the positions of
    // sd_deform, and each displacement turned by the J sd_deform_frames gives.
    std::vector<float> bent = arm.rest;
    for (int bone = 1; bone < 3; ++bone) {
        const float turned_z[16] = {0, 1, 0, 0, -1, 0, 0, 0, 0, 0, 1, 0, 1, bone == 1 ? 0.0f : 1.0f, 0, 1};
        std::copy(turned_z, turned_z + 16, &bent[16 * static_cast<size_t>(bone)]);
    }
    // Two vertices of three displaced (the others get no J).
    std::vector<int32_t> which;
    std::vector<float> disp;
    for (int v = 0; v < V; ++v)
        if (v % 3 != 0) {
            which.push_back(v);
            for (int c = 0; c < 3; ++c) disp.push_back(0.01f * static_cast<float>((3 * v + c) * 7 % 5 - 2));
        }
    const int32_t M = static_cast<int32_t>(which.size());
    std::vector<float> at(3 * V, 42.0f), turned(3 * static_cast<size_t>(M), 42.0f);
    const auto displaced = [&](int32_t count, const int32_t* vertices, const float* moves) {
        return sd_deform_displaced(d, 3, bent.data(), V, count, vertices, moves, at.data(), turned.data());
    };
    disp[7] = kNaN;
    expect_error(displaced(M, which.data(), disp.data()), SD_ERR_INVALID_ARGUMENT, "NaN displacement");
    disp[7] = 2e12f;
    expect_error(displaced(M, which.data(), disp.data()), SD_ERR_INVALID_ARGUMENT, "enormous displacement");
    disp[7] = 0.0f;
    expect_error(displaced(M, which.data(), nullptr), SD_ERR_INVALID_ARGUMENT, "NULL displacements");
    expect_error(displaced(-1, which.data(), disp.data()), SD_ERR_INVALID_ARGUMENT, "negative count");
    std::vector<int32_t> bad = which;
    std::swap(bad[0], bad[1]);
    expect_error(displaced(M, bad.data(), disp.data()), SD_ERR_INVALID_ARGUMENT, "vertices not ascending");
    bad = which;
    bad.back() = V;
    expect_error(displaced(M, bad.data(), disp.data()), SD_ERR_INVALID_ARGUMENT, "vertex out of range");
    for (float x : at) ASSERT_EQ(x, 42.0f) << "output touched by a failed call";
    for (float x : turned) ASSERT_EQ(x, 42.0f) << "output touched by a failed call";
    ASSERT_EQ(displaced(M, which.data(), disp.data()), SD_OK) << sd_last_error();
    ASSERT_EQ(sd_deform(d, 3, bent.data(), V, out.data()), SD_OK);
    ASSERT_EQ(sd_deform_frames(d, 3, bent.data(), V, pos.data(), frames.data()), SD_OK);
    for (int i = 0; i < 3 * V; ++i) ASSERT_NEAR(at[i], out[i], 1e-6f);
    float moved = 0.0f;  // how far J d is from d somewhere: the forearm's turn
    for (int32_t k = 0; k < M; ++k)
        for (int r = 0; r < 3; ++r) {
            const int v = which[k];
            float jd = 0.0f;
            for (int c = 0; c < 3; ++c) jd += frames[3 * (r * V + v) + c] * disp[3 * k + c];
            ASSERT_NEAR(turned[3 * k + r], jd, 1e-6f) << "vertex " << v << " row " << r;
            moved = std::max(moved, std::abs(turned[3 * k + r] - disp[3 * k + r]));
        }
    // None displaced: the positions alone.
    std::fill(at.begin(), at.end(), 42.0f);
    ASSERT_EQ(displaced(0, nullptr, nullptr), SD_OK) << sd_last_error();
    for (int i = 0; i < 3 * V; ++i) ASSERT_NEAR(at[i], out[i], 1e-6f);
    EXPECT_GT(moved, 0.02f);
    sd_deformer_destroy(d);
    sd_binding_destroy(b);
}

TEST(CApi, HoldingTheJointsVolumeRefusesBadTrianglesAndChangesNothing) {
    const AbiArm arm;
    sd_binding* b = nullptr;
    ASSERT_EQ(arm.bind(&b), SD_OK) << sd_last_error();
    sd_deformer* d = nullptr;
    ASSERT_EQ(sd_deformer_create(arm.rig, b, &d), SD_OK) << sd_last_error();
    const int V = arm.vertex_count();
    std::vector<float> bent = arm.rest, before(3 * V), after(3 * V);
    bent[12 + 16] = 1.1f;  // move the forearm
    ASSERT_EQ(sd_deform(d, 3, bent.data(), V, before.data()), SD_OK);
    const int32_t good[6] = {0, 1, 16, 1, 17, 16}, out_of_range[3] = {0, 1, V}, negative[3] = {0, -1, 2};
    int32_t held = -1;
    expect_error(sd_deformer_hold_joint_volumes(nullptr, V, 2, good, &held), SD_ERR_INVALID_ARGUMENT, "NULL deformer");
    expect_error(sd_deformer_hold_joint_volumes(d, V, 2, nullptr, &held), SD_ERR_INVALID_ARGUMENT, "NULL triangles");
    expect_error(sd_deformer_hold_joint_volumes(d, V + 1, 2, good, &held), SD_ERR_MISMATCH, "vertex count");
    expect_error(sd_deformer_hold_joint_volumes(d, V, -2, good, &held), SD_ERR_INVALID_ARGUMENT, "negative count");
    expect_error(sd_deformer_hold_joint_volumes(d, V, 1, out_of_range, &held), SD_ERR_INVALID_ARGUMENT,
                 "corner out of range");
    expect_error(sd_deformer_hold_joint_volumes(d, V, 1, negative, &held), SD_ERR_INVALID_ARGUMENT, "negative corner");
    EXPECT_EQ(held, -1);
    ASSERT_EQ(sd_deform(d, 3, bent.data(), V, after.data()), SD_OK);
    EXPECT_EQ(after, before);
    // Valid triangles (a patch that loses nothing worth holding), then none: no joint held.
    ASSERT_EQ(sd_deformer_hold_joint_volumes(d, V, 2, good, &held), SD_OK) << sd_last_error();
    EXPECT_EQ(held, 0);
    ASSERT_EQ(sd_deformer_hold_joint_volumes(d, V, 0, nullptr, nullptr), SD_OK) << sd_last_error();
    ASSERT_EQ(sd_deform(d, 3, bent.data(), V, after.data()), SD_OK);
    EXPECT_EQ(after, before);
    // Another deformer's tables: of the same rig only.
    const AbiArm other(0.12f);
    sd_binding* ob = nullptr;
    ASSERT_EQ(other.bind(&ob), SD_OK) << sd_last_error();
    sd_deformer* od = nullptr;
    ASSERT_EQ(sd_deformer_create(other.rig, ob, &od), SD_OK) << sd_last_error();
    expect_error(sd_deformer_hold_joint_volumes_of(d, od, &held), SD_ERR_MISMATCH, "another rig");
    expect_error(sd_deformer_hold_joint_volumes_of(d, nullptr, &held), SD_ERR_INVALID_ARGUMENT, "NULL source");
    sd_deformer* same = nullptr;
    ASSERT_EQ(sd_deformer_create(arm.rig, b, &same), SD_OK);
    held = -1;
    EXPECT_EQ(sd_deformer_hold_joint_volumes_of(d, same, &held), SD_OK) << sd_last_error();
    EXPECT_EQ(held, 0);
    // The tables as a blob (deform/joint_volume_blob.h; its content: JointVolume tests): for the
    // same rig only, undamaged.
    int64_t size = 0;
    ASSERT_EQ(sd_deformer_serialize_joint_volumes(d, nullptr, 0, &size), SD_OK) << sd_last_error();
    std::vector<uint8_t> blob(static_cast<size_t>(size));
    ASSERT_EQ(sd_deformer_serialize_joint_volumes(d, blob.data(), size, &size), SD_OK) << sd_last_error();
    held = -1;
    EXPECT_EQ(sd_deformer_load_joint_volumes(same, blob.data(), size, &held), SD_OK) << sd_last_error();
    EXPECT_EQ(held, 0);
    expect_error(sd_deformer_load_joint_volumes(od, blob.data(), size, &held), SD_ERR_MISMATCH, "another rig");
    std::vector<uint8_t> damaged = blob;
    damaged.back() ^= 0x40;
    expect_error(sd_deformer_load_joint_volumes(same, damaged.data(), size, &held), SD_ERR_CORRUPT_DATA, "checksum");
    expect_error(sd_deformer_load_joint_volumes(same, blob.data(), -1, &held), SD_ERR_CORRUPT_DATA, "negative size");
    expect_error(sd_deformer_load_joint_volumes(nullptr, blob.data(), size, &held), SD_ERR_INVALID_ARGUMENT, "NULL");
    expect_error(sd_deformer_serialize_joint_volumes(nullptr, nullptr, 0, &size), SD_ERR_INVALID_ARGUMENT, "NULL");
    sd_deformer_destroy(same);
    sd_deformer_destroy(od);
    sd_binding_destroy(ob);
    sd_deformer_destroy(d);
    sd_binding_destroy(b);
}

TEST(CApi, TheSkinsTrianglesAreCheckedAndBadOnesChangeNothing) {
    // The arm's sweep is no trunk: its skin's triangles fill nothing, and a frame deforms as
    // before, bit for bit (the fill itself: trunk_fill_test.cpp).
    const AbiArm arm;
    sd_binding* b = nullptr;
    ASSERT_EQ(arm.bind(&b), SD_OK) << sd_last_error();
    sd_deformer* d = nullptr;
    ASSERT_EQ(sd_deformer_create(arm.rig, b, &d), SD_OK) << sd_last_error();
    const int V = arm.vertex_count();
    std::vector<float> bent = arm.rest, before(3 * V), after(3 * V);
    bent[12 + 16] = 1.1f;  // move the forearm
    ASSERT_EQ(sd_deform(d, 3, bent.data(), V, before.data()), SD_OK);
    const int32_t good[6] = {0, 1, 16, 1, 17, 16}, out_of_range[3] = {0, 1, V}, negative[3] = {0, -1, 2};
    expect_error(sd_deformer_set_skin_triangles(nullptr, V, 2, good), SD_ERR_INVALID_ARGUMENT, "NULL deformer");
    expect_error(sd_deformer_set_skin_triangles(d, V, 2, nullptr), SD_ERR_INVALID_ARGUMENT, "NULL triangles");
    expect_error(sd_deformer_set_skin_triangles(d, V + 1, 2, good), SD_ERR_MISMATCH, "vertex count");
    expect_error(sd_deformer_set_skin_triangles(d, V, -2, good), SD_ERR_INVALID_ARGUMENT, "negative count");
    expect_error(sd_deformer_set_skin_triangles(d, V, 1, out_of_range), SD_ERR_INVALID_ARGUMENT, "corner out of range");
    expect_error(sd_deformer_set_skin_triangles(d, V, 1, negative), SD_ERR_INVALID_ARGUMENT, "negative corner");
    ASSERT_EQ(sd_deform(d, 3, bent.data(), V, after.data()), SD_OK);
    EXPECT_EQ(after, before);
    ASSERT_EQ(sd_deformer_set_skin_triangles(d, V, 2, good), SD_OK) << sd_last_error();
    ASSERT_EQ(sd_deform(d, 3, bent.data(), V, after.data()), SD_OK);
    EXPECT_EQ(after, before);
    ASSERT_EQ(sd_deformer_set_skin_triangles(d, V, 0, nullptr), SD_OK) << sd_last_error();
    // Filled as another deformer: of the same rig only.
    sd_deformer* same = nullptr;
    ASSERT_EQ(sd_deformer_create(arm.rig, b, &same), SD_OK);
    EXPECT_EQ(sd_deformer_fill_trunk_as(d, same), SD_OK) << sd_last_error();
    expect_error(sd_deformer_fill_trunk_as(nullptr, same), SD_ERR_INVALID_ARGUMENT, "NULL deformer");
    expect_error(sd_deformer_fill_trunk_as(d, nullptr), SD_ERR_INVALID_ARGUMENT, "NULL source");
    const AbiArm other(0.12f);
    sd_binding* ob = nullptr;
    ASSERT_EQ(other.bind(&ob), SD_OK) << sd_last_error();
    sd_deformer* od = nullptr;
    ASSERT_EQ(sd_deformer_create(other.rig, ob, &od), SD_OK) << sd_last_error();
    expect_error(sd_deformer_fill_trunk_as(d, od), SD_ERR_MISMATCH, "another rig");
    ASSERT_EQ(sd_deform(d, 3, bent.data(), V, after.data()), SD_OK);
    EXPECT_EQ(after, before);
    sd_deformer_destroy(od);
    sd_binding_destroy(ob);
    sd_deformer_destroy(same);
    sd_deformer_destroy(d);
    sd_binding_destroy(b);
}

// Blender's relative keys: reference + Σ value (key − its relative key), as displacements from
// the rest, for the vertices they move.
TEST(CApi, ShapeKeysMixAsBlenderMixesThem) {
    const std::vector<float> rest = {0, 0, 0, 1, 0, 0, 2, 0, 0, 3, 0, 0};
    std::vector<float> reference = rest, a, b;
    reference[11] += 0.5f;  // the basis itself moved vertex 3
    a = reference;
    a[3] += 0.1f;  // key A moves vertex 1 along x
    b = a;
    b[7] += 0.2f;  // key B, relative to A, moves vertex 2 along y
    std::vector<float> blocks = reference;
    blocks.insert(blocks.end(), a.begin(), a.end());
    blocks.insert(blocks.end(), b.begin(), b.end());
    const int32_t terms[4] = {1, 0, 2, 1};  // A relative to the reference, B relative to A
    float values[2] = {0.5f, 2.0f};
    int32_t count = -7, moved[4] = {-7, -7, -7, -7};
    float moves[12];
    std::fill(moves, moves + 12, 42.0f);
    const auto mix = [&](const float* keys, const int32_t* which) {
        return sd_mix_shape_keys(4, rest.data(), 3, keys, 2, which, values, &count, moved, moves);
    };
    const int32_t outside[4] = {1, 0, 3, 1};
    expect_error(mix(blocks.data(), outside), SD_ERR_INVALID_ARGUMENT, "a block outside");
    values[1] = kNaN;
    expect_error(mix(blocks.data(), terms), SD_ERR_INVALID_ARGUMENT, "NaN value");
    values[1] = 2.0f;
    std::vector<float> broken = blocks;
    broken[20] = kNaN;
    expect_error(mix(broken.data(), terms), SD_ERR_INVALID_ARGUMENT, "NaN position");
    EXPECT_EQ(count, -7);
    for (float m : moves) ASSERT_EQ(m, 42.0f) << "output touched by a failed call";
    ASSERT_EQ(mix(blocks.data(), terms), SD_OK) << sd_last_error();
    ASSERT_EQ(count, 3);  // vertex 0 stays
    EXPECT_EQ(std::vector<int32_t>(moved, moved + 3), (std::vector<int32_t>{1, 2, 3}));
    const float expected[9] = {0.05f, 0, 0, 0, 0.4f, 0, 0, 0, 0.5f};
    for (int i = 0; i < 9; ++i) EXPECT_NEAR(moves[i], expected[i], 1e-6f) << i;
    // No key on: the basis alone.
    ASSERT_EQ(sd_mix_shape_keys(4, rest.data(), 1, blocks.data(), 0, nullptr, nullptr, &count, moved, moves), SD_OK);
    ASSERT_EQ(count, 1);
    EXPECT_EQ(moved[0], 3);
}

TEST(CApi, ComposedOffsetsAreTheSumsMadeOneArrayAtATime) {
    // Values of mixed magnitudes, so that another order of the sums ((base + positions) -
    // rest, say) rounds differently somewhere; enough vertices for several blocks on the
    // threads, moved ones either side of the blocks' edges (8192 vertices a block).
    const int V = 20000;
    std::mt19937 rng(7);
    std::uniform_real_distribution<float> small(-1e-3f, 1e-3f), large(-50.0f, 50.0f);
    std::vector<float> p(3 * V), r(3 * V), base(3 * V);
    for (int i = 0; i < 3 * V; ++i) {
        r[i] = large(rng);
        p[i] = r[i] + small(rng);
        base[i] = large(rng) * 1e-2f;
    }
    const std::vector<int32_t> moved = {3, 17, 18, 250, 8191, 8192, 16383, 16384, 19999};
    const int M = static_cast<int>(moved.size());
    std::vector<float> turned(3 * M), d(3 * M);
    for (int i = 0; i < 3 * M; ++i) turned[i] = small(rng), d[i] = small(rng);
    for (const bool with_base : {false, true})
        for (const bool with_d : {false, true}) {
            std::vector<float> expected(3 * V), diff(3 * V), change(3 * M);
            for (int i = 0; i < 3 * V; ++i) diff[i] = p[i] - r[i];
            for (int i = 0; i < 3 * V; ++i) expected[i] = with_base ? base[i] + diff[i] : diff[i];
            for (int i = 0; i < 3 * M; ++i) change[i] = with_d ? turned[i] - d[i] : turned[i];
            for (int i = 0; i < M; ++i)
                for (int c = 0; c < 3; ++c) expected[3 * moved[i] + c] += change[3 * i + c];
            std::vector<float> out(3 * V, 42.0f);
            ASSERT_EQ(sd_compose_offsets(V, p.data(), r.data(), with_base ? base.data() : nullptr, M, moved.data(),
                                         turned.data(), with_d ? d.data() : nullptr, out.data()),
                      SD_OK)
                << sd_last_error();
            for (int i = 0; i < 3 * V; ++i)
                ASSERT_EQ(out[i], expected[i]) << i << " base " << with_base << " d " << with_d;
            if (with_base) {  // into the base itself
                std::vector<float> in_place = base;
                ASSERT_EQ(sd_compose_offsets(V, p.data(), r.data(), in_place.data(), M, moved.data(), turned.data(),
                                             with_d ? d.data() : nullptr, in_place.data()),
                          SD_OK);
                EXPECT_EQ(in_place, expected);
            }
        }
    // Refused, nothing written: a vertex twice, out of order, outside the mesh, a NULL.
    std::vector<float> out(3 * V, 42.0f);
    const auto compose = [&](const std::vector<int32_t>& which) {
        return sd_compose_offsets(V, p.data(), r.data(), nullptr, static_cast<int32_t>(which.size()), which.data(),
                                  turned.data(), nullptr, out.data());
    };
    expect_error(compose({3, 3}), SD_ERR_INVALID_ARGUMENT, "not ascending");
    expect_error(compose({17, 3}), SD_ERR_INVALID_ARGUMENT, "not ascending");
    expect_error(compose({3, V}), SD_ERR_INVALID_ARGUMENT, "not in [0, vertex_count)");
    expect_error(compose({-1}), SD_ERR_INVALID_ARGUMENT, "not in [0, vertex_count)");
    expect_error(sd_compose_offsets(V, p.data(), nullptr, nullptr, 0, nullptr, nullptr, nullptr, out.data()),
                 SD_ERR_INVALID_ARGUMENT, "NULL");
    expect_error(sd_compose_offsets(V, p.data(), r.data(), nullptr, 1, moved.data(), nullptr, nullptr, out.data()),
                 SD_ERR_INVALID_ARGUMENT, "NULL");
    for (float o : out) ASSERT_EQ(o, 42.0f) << "output touched by a failed call";
}

TEST(CApi, AFrameInOnePassIsTheThreeCallsToTheBit) {
    // sd_deform_frame against sd_deform_displaced, sd_output_check_run and sd_compose_offsets
    // called one after the other: a denser arm (several of the kernel's blocks of 2048
    // vertices), its tip also on the hand bone (blended vertices), the forearm bent 70°, moved
    // vertices either side of the blocks' edges.
    AbiArm arm;
    arm.mesh.clear();
    for (int r = 0; r <= 400; ++r)
        for (int s = 0; s < 24; ++s) {
            const double th = 2 * M_PI * s / 24;
            arm.mesh.insert(arm.mesh.end(), {r / 200.0f, float(0.1 * std::cos(th)), float(0.07 * std::sin(th))});
        }
    const int V = arm.vertex_count();
    std::vector<int32_t> sweep_ids(V, 0), bone_ids(V, -1), skin(V);
    std::vector<float> sweep_w(V, 1.0f), bone_w(V, 0.0f), skin_w(V, 1.0f), lengths = {1.0f, 1.0f, 0.3f};
    for (int v = 0; v < V; ++v) {
        const float x = arm.mesh[3 * v];
        if (x > 1.8f) bone_ids[v] = 2, bone_w[v] = (x - 1.8f) * 2.0f;
        skin[v] = x < 1.0f ? 0 : (x < 2.0f ? 1 : 2);
    }
    sd_binding* b = nullptr;
    ASSERT_EQ(sd_bind(arm.rig, V, arm.mesh.data(), 1, sweep_ids.data(), sweep_w.data(), 1, bone_ids.data(),
                      bone_w.data(), &b),
              SD_OK)
        << sd_last_error();
    sd_deformer* d = nullptr;
    ASSERT_EQ(sd_deformer_create(arm.rig, b, &d), SD_OK) << sd_last_error();
    sd_output_check* check = nullptr;
    ASSERT_EQ(sd_output_check_create(V, arm.mesh.data(), 3, arm.rest.data(), lengths.data(), 1, skin.data(),
                                     skin_w.data(), 0.05f, &check),
              SD_OK)
        << sd_last_error();
    ASSERT_GT(V, 4 * 2048);
    std::vector<float> bent = arm.rest;
    const float c = std::cos(70 * float(M_PI) / 180), s = std::sin(70 * float(M_PI) / 180);
    for (int bone = 1; bone < 3; ++bone) {
        const float m[16] = {c, s, 0, 0, -s, c, 0, 0, 0, 0, 1, 0, 1 + (bone == 2 ? c : 0.0f), bone == 2 ? s : 0.0f,
                             0, 1};
        std::copy(m, m + 16, &bent[16 * static_cast<size_t>(bone)]);
    }
    const std::vector<int32_t> moved = {0, 5, 2047, 2048, 4095, 4096, 6000, 8191, 8192, 9000, V - 1};
    const int32_t M = static_cast<int32_t>(moved.size());
    std::vector<float> disp(3 * M), base(3 * V), rest(3 * V);
    for (int i = 0; i < 3 * M; ++i) disp[i] = 0.003f * static_cast<float>(i % 7) - 0.01f;
    ASSERT_EQ(sd_deform(d, 3, arm.rest.data(), V, rest.data()), SD_OK);
    for (int i = 0; i < 3 * V; ++i) base[i] = rest[i] + 1e-3f * static_cast<float>(i % 11);
    for (const int32_t count : {0, M})
        // 1.1: some of the bent skin is beyond it (1.2 was, until the elbow's tangent was shortened)
        for (const float limit : {3.0f, 1.1f})
            for (const bool with_base : {false, true})
                for (const int subtract : {0, 1}) {
                    SCOPED_TRACE("moved " + std::to_string(count) + " limit " + std::to_string(limit) + " base " +
                                 std::to_string(with_base) + " subtract " + std::to_string(subtract));
                    std::vector<float> pos(3 * V), turned(3 * M), composed(3 * V);
                    int32_t beyond = -7, vertex = -7, bone = -7;
                    float ratio = -7.0f;
                    ASSERT_EQ(sd_deform_frame(d, 3, bent.data(), V, count, moved.data(), disp.data(), pos.data(),
                                              turned.data(), check, limit, &beyond, &ratio, &vertex, &bone, rest.data(),
                                              with_base ? base.data() : nullptr, subtract, composed.data()),
                              SD_OK)
                        << sd_last_error();
                    std::vector<float> pos1(3 * V), turned1(3 * M), composed1(3 * V);
                    int32_t beyond1 = -1, vertex1 = -1, bone1 = -1;
                    float ratio1 = -1.0f;
                    ASSERT_EQ(sd_deform_displaced(d, 3, bent.data(), V, count, moved.data(), disp.data(), pos1.data(),
                                                  turned1.data()),
                              SD_OK);
                    ASSERT_EQ(sd_output_check_run(check, 3, bent.data(), V, pos1.data(), limit, &beyond1, &ratio1,
                                                  &vertex1, &bone1, nullptr),
                              SD_OK);
                    ASSERT_EQ(sd_compose_offsets(V, pos1.data(), rest.data(), with_base ? base.data() : nullptr, count,
                                                 moved.data(), turned1.data(), subtract ? disp.data() : nullptr,
                                                 composed1.data()),
                              SD_OK);
                    EXPECT_EQ(pos, pos1);
                    if (count) EXPECT_EQ(turned, turned1);
                    EXPECT_EQ(composed, composed1);
                    EXPECT_EQ(beyond, beyond1);
                    EXPECT_EQ(ratio, ratio1);
                    EXPECT_EQ(vertex, vertex1);
                    EXPECT_EQ(bone, bone1);
                    if (limit < 2.0f)
                        EXPECT_GT(beyond, 0) << "the tight limit finds the bend";
                    else
                        EXPECT_EQ(beyond, 0);
                }
    // Without a check or a composition: the positions alone, the verdict empty.
    std::vector<float> pos(3 * V), pos1(3 * V);
    int32_t beyond = -7, vertex = -7, bone = -7;
    float ratio = -7.0f;
    ASSERT_EQ(sd_deform_frame(d, 3, bent.data(), V, 0, nullptr, nullptr, pos.data(), nullptr, nullptr, 0.0f, &beyond,
                              &ratio, &vertex, &bone, nullptr, nullptr, 0, nullptr),
              SD_OK)
        << sd_last_error();
    ASSERT_EQ(sd_deform(d, 3, bent.data(), V, pos1.data()), SD_OK);
    EXPECT_EQ(pos, pos1);
    EXPECT_EQ(beyond, 0);
    EXPECT_EQ(ratio, 0.0f);
    EXPECT_EQ(vertex, -1);
    EXPECT_EQ(bone, -1);
    // Refused, nothing written.
    std::vector<float> out(3 * V, 42.0f), turned(3 * M, 42.0f), composed(3 * V, 42.0f);
    const auto frame = [&](const float* pose, float limit, const float* rest_in, float* into, int32_t vertices) {
        return sd_deform_frame(d, 3, pose, vertices, M, moved.data(), disp.data(), out.data(), turned.data(), check,
                               limit, nullptr, nullptr, nullptr, nullptr, rest_in, nullptr, 1, into);
    };
    std::vector<float> nan_pose = bent;
    nan_pose[13] = kNaN;
    expect_error(frame(nan_pose.data(), 3.0f, rest.data(), composed.data(), V), SD_ERR_INVALID_ARGUMENT, "NaN pose");
    expect_error(frame(bent.data(), 0.0f, rest.data(), composed.data(), V), SD_ERR_INVALID_ARGUMENT, "limit 0");
    expect_error(frame(bent.data(), kNaN, rest.data(), composed.data(), V), SD_ERR_INVALID_ARGUMENT, "NaN limit");
    expect_error(frame(bent.data(), 3.0f, nullptr, composed.data(), V), SD_ERR_INVALID_ARGUMENT, "NULL rest");
    expect_error(frame(bent.data(), 3.0f, rest.data(), out.data(), V), SD_ERR_INVALID_ARGUMENT, "composed = positions");
    expect_error(frame(bent.data(), 3.0f, rest.data(), composed.data(), V - 1), SD_ERR_MISMATCH, "vertex count");
    sd_output_check* other = nullptr;
    ASSERT_EQ(sd_output_check_create(V - 1, arm.mesh.data(), 3, arm.rest.data(), lengths.data(), 1, skin.data(),
                                     skin_w.data(), 0.05f, &other),
              SD_OK);
    expect_error(sd_deform_frame(d, 3, bent.data(), V, 0, nullptr, nullptr, out.data(), nullptr, other, 3.0f, nullptr,
                                 nullptr, nullptr, nullptr, nullptr, nullptr, 0, nullptr),
                 SD_ERR_MISMATCH, "check of another mesh");
    for (float x : out) ASSERT_EQ(x, 42.0f) << "output touched by a failed call";
    for (float x : turned) ASSERT_EQ(x, 42.0f) << "output touched by a failed call";
    for (float x : composed) ASSERT_EQ(x, 42.0f) << "output touched by a failed call";
    sd_output_check_destroy(other);
    sd_output_check_destroy(check);
    sd_deformer_destroy(d);
    sd_binding_destroy(b);
}

TEST(CApi, BlobsRoundTripExactly) {
    AbiArm arm;
    int64_t size = 0;
    ASSERT_EQ(sd_rig_serialize(arm.rig, nullptr, 0, &size), SD_OK);
    std::vector<uint8_t> blob(size);
    ASSERT_EQ(sd_rig_serialize(arm.rig, blob.data(), size, &size), SD_OK);
    sd_rig* copy = nullptr;
    ASSERT_EQ(sd_rig_deserialize(blob.data(), size, &copy), SD_OK) << sd_last_error();
    std::vector<uint8_t> again(size);
    ASSERT_EQ(sd_rig_serialize(copy, again.data(), size, &size), SD_OK);
    EXPECT_EQ(blob, again);

    sd_binding* b = nullptr;
    ASSERT_EQ(arm.bind(&b), SD_OK);
    ASSERT_EQ(sd_binding_serialize(b, nullptr, 0, &size), SD_OK);
    std::vector<uint8_t> bblob(size);
    ASSERT_EQ(sd_binding_serialize(b, bblob.data(), size, &size), SD_OK);
    sd_binding* b2 = nullptr;
    ASSERT_EQ(sd_binding_deserialize(bblob.data(), size, &b2), SD_OK) << sd_last_error();
    // The loaded rig and binding deform exactly like the originals.
    sd_deformer *d1 = nullptr, *d2 = nullptr;
    ASSERT_EQ(sd_deformer_create(arm.rig, b, &d1), SD_OK);
    ASSERT_EQ(sd_deformer_create(copy, b2, &d2), SD_OK) << sd_last_error();
    std::vector<float> pose = arm.rest, o1(arm.mesh.size()), o2(arm.mesh.size());
    pose[12 + 16] = 1.1f;  // move the forearm a little
    ASSERT_EQ(sd_deform(d1, 3, pose.data(), arm.vertex_count(), o1.data()), SD_OK);
    ASSERT_EQ(sd_deform(d2, 3, pose.data(), arm.vertex_count(), o2.data()), SD_OK);
    EXPECT_EQ(o1, o2);
    sd_deformer_destroy(d1);
    sd_deformer_destroy(d2);
    sd_binding_destroy(b);
    sd_binding_destroy(b2);
    sd_rig_destroy(copy);
}

TEST(CApi, ARigReadBackIsTheRigThatWasSaved) {
    // Orientations that are unit only to float precision, as a caller sends them: the rig is
    // normalised once on the way in; loading its blob must not change a bit, or a binding
    // saved with it would no longer match (its fingerprint covers the rig's bytes).
    AbiArm arm;
    for (int k = 0; k < 7; ++k) {
        const float a = 0.3f + 0.1f * k, c = std::cos(a), s = std::sin(a);
        const float q[4] = {0.5f * (c + s), 0.5f * (c - s), 0.5f * (c + s), 0.5f * (c - s)};
        for (int i = 0; i < 4; ++i) arm.orientations[4 * k + i] = q[i] * 1.0000003f;
    }
    sd_rig* rig = nullptr;
    ASSERT_EQ(sd_rig_create(3, arm.parents.data(), arm.rest.data(), arm.heads.data(), arm.tails.data(), &rig), SD_OK);
    ASSERT_EQ(sd_rig_add_sweep(rig, 7, arm.centers.data(), arm.orientations.data(), arm.half_axes.data(),
                               arm.bones.data(), arm.joint_parents.data(), arm.fractions.data(), nullptr),
              SD_OK)
        << sd_last_error();
    const auto blob_of = [](const sd_rig* r) {
        int64_t n = 0;
        sd_rig_serialize(r, nullptr, 0, &n);
        std::vector<uint8_t> b(n);
        sd_rig_serialize(r, b.data(), n, &n);
        return b;
    };
    const std::vector<uint8_t> saved = blob_of(rig);
    sd_rig* loaded = nullptr;
    ASSERT_EQ(sd_rig_deserialize(saved.data(), static_cast<int64_t>(saved.size()), &loaded), SD_OK);
    EXPECT_EQ(blob_of(loaded), saved);
    std::vector<int32_t> ids(arm.vertex_count(), 0);
    std::vector<float> w(arm.vertex_count(), 1.0f);
    sd_binding* b = nullptr;
    ASSERT_EQ(sd_bind(rig, arm.vertex_count(), arm.mesh.data(), 1, ids.data(), w.data(), 0, nullptr, nullptr, &b),
              SD_OK);
    sd_deformer* d = nullptr;
    EXPECT_EQ(sd_deformer_create(loaded, b, &d), SD_OK) << sd_last_error();
    sd_deformer_destroy(d);
    sd_binding_destroy(b);
    sd_rig_destroy(loaded);
    sd_rig_destroy(rig);
}

TEST(CApi, CorruptOrTruncatedBlobsAreRefused) {
    AbiArm arm;
    int64_t size = 0;
    sd_rig_serialize(arm.rig, nullptr, 0, &size);
    std::vector<uint8_t> blob(size);
    sd_rig_serialize(arm.rig, blob.data(), size, &size);
    sd_rig* out = nullptr;
    for (int64_t cut : {int64_t(0), int64_t(3), int64_t(16), size / 2, size - 1})
        expect_error(sd_rig_deserialize(blob.data(), cut, &out), SD_ERR_CORRUPT_DATA, "truncated");
    for (int64_t i = 0; i < size; i += 7) {  // any flipped bit is caught (checksum, magic, size)
        std::vector<uint8_t> bad = blob;
        bad[i] ^= 0x10;
        expect_error(sd_rig_deserialize(bad.data(), size, &out), SD_ERR_CORRUPT_DATA, "flipped bit");
    }
    expect_error(sd_rig_deserialize(nullptr, 100, &out), SD_ERR_CORRUPT_DATA, "NULL");
    expect_error(sd_rig_deserialize(blob.data(), -5, &out), SD_ERR_CORRUPT_DATA, "negative size");
    EXPECT_EQ(out, nullptr);
    sd_binding* b = nullptr;
    expect_error(sd_binding_deserialize(blob.data(), size, &b), SD_ERR_CORRUPT_DATA, "rig blob as binding");
    std::vector<uint8_t> small(3);
    expect_error(sd_rig_serialize(arm.rig, small.data(), 3, &size), SD_ERR_INVALID_ARGUMENT, "small buffer");
}

TEST(CApi, BindingOfAnotherRigIsAMismatch) {
    AbiArm arm, other;
    other.half_axes[0] = 0.11f;
    sd_rig* rig2 = nullptr;
    ASSERT_EQ(sd_rig_create(3, other.parents.data(), other.rest.data(), other.heads.data(), other.tails.data(), &rig2),
              SD_OK);
    ASSERT_EQ(sd_rig_add_sweep(rig2, 7, other.centers.data(), other.orientations.data(), other.half_axes.data(),
                               other.bones.data(), other.joint_parents.data(), other.fractions.data(), nullptr),
              SD_OK);
    sd_binding* b = nullptr;
    ASSERT_EQ(arm.bind(&b), SD_OK);
    sd_deformer* d = nullptr;
    expect_error(sd_deformer_create(rig2, b, &d), SD_ERR_MISMATCH, "other rig");
    EXPECT_EQ(d, nullptr);
    sd_binding_destroy(b);
    sd_rig_destroy(rig2);
}

TEST(CApi, EvaluatesTheSweepAndItsVolume) {
    AbiArm arm;
    const float u[3] = {0.0f, 0.5f, 1.0f};
    float c[9], n[9], ab[6];
    ASSERT_EQ(sd_rig_evaluate_sweep(arm.rig, 0, 3, u, c, nullptr, n, nullptr, ab), SD_OK);
    EXPECT_NEAR(c[3], 1.0f, 1e-6);
    EXPECT_NEAR(n[6], 1.0f, 1e-6);
    EXPECT_NEAR(ab[2], 0.1f, 1e-6);
    double v = 0;
    ASSERT_EQ(sd_rig_sweep_rest_volume(arm.rig, 0, &v), SD_OK);
    EXPECT_NEAR(v, M_PI * 0.1 * 0.07 * 2.0, 1e-6);
    const float bad[1] = {1.5f};
    expect_error(sd_rig_evaluate_sweep(arm.rig, 0, 1, bad, c, nullptr, nullptr, nullptr, nullptr),
                 SD_ERR_INVALID_ARGUMENT, "u out of range");
}

}  // namespace
