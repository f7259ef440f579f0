// The skin beside a trunk's spine follows the spine's bones (fit/spine_skin.h): near the
// spine a vertex's trunk weight goes to the spine's bones by its own skin weights, fading to
// the sweep further out; skin on other bones, skin far from the spine and limbs keep theirs.
#include "fit/spine_skin.h"
#include "rig/key_motion.h"

#include <gtest/gtest.h>

#include <glm/gtc/matrix_transform.hpp>

#include <vector>

namespace sd {
namespace {

/// A trunk: three 10 cm bones up z, a fourth bone (an arm) off the top, and a key every 2.5 cm
/// of half-axes 15 x 10 cm (the depth, along y, 10): far thicker than its links are long.
/// Its chain: the first three bones, sweep 0.
struct Trunk {
    Rig rig;
    fit::ChainSet chains;
    std::vector<int> chain_sweep{0};
};

Trunk trunk(double half_a, double half_b) {
    std::vector<dmat4> rest;
    std::vector<dvec3> heads{{0, 0, 0}, {0, 0, 0.1}, {0, 0, 0.2}, {0, 0, 0.3}},
        tails{{0, 0, 0.1}, {0, 0, 0.2}, {0, 0, 0.3}, {0.2, 0, 0.3}};
    for (const dvec3& h : heads) rest.push_back(glm::translate(dmat4(1.0), h));
    Trunk t;
    Rig& rig = t.rig;
    rig.skeleton = Skeleton::build({-1, 0, 1, 2}, rest, heads, tails);
    std::vector<KeyEllipse> keys;
    for (double z = 0.0125; z < 0.3; z += 0.025) {
        KeyEllipse e;
        e.center = dvec3(0, 0, z);
        e.a = half_a;
        e.b = half_b;
        e.bone = z < 0.1 ? 0 : z < 0.2 ? 1 : 2;
        keys.push_back(e);
    }
    rig.add_sweep(keys);
    fit::Chain torso;
    torso.kind = fit::ChainKind::Torso;
    torso.bones = {0, 1, 2};
    t.chains.chains.push_back(torso);
    return t;
}

struct Skin {
    std::vector<float> positions;
    std::vector<int32_t> bones;  // 2 slots a vertex
    std::vector<float> weights;
    void add(const dvec3& p, int b0, float w0, int b1 = -1, float w1 = 0.0f) {
        positions.insert(positions.end(), {float(p.x), float(p.y), float(p.z)});
        bones.insert(bones.end(), {b0, b1});
        weights.insert(weights.end(), {w0, w1});
    }
};

/// Every vertex on sweep 0 with weight `on_sweep`, the rest of its weight on bone 3.
fit::RegionWeights on_the_sweep(int V, const std::vector<float>& on_sweep) {
    fit::RegionWeights r;
    r.sweep_slots = 1;
    r.bone_slots = 1;
    r.sweep_ids.assign(V, 0);
    r.sweep_weights = on_sweep;
    for (int v = 0; v < V; ++v) {
        r.bone_ids.push_back(on_sweep[v] < 1.0f ? 3 : -1);
        r.bone_weights.push_back(1.0f - on_sweep[v]);
    }
    return r;
}

float bone_weight(const fit::RegionWeights& r, int v, int bone) {
    float w = 0.0f;
    for (int i = 0; i < r.bone_slots; ++i)
        if (r.bone_ids[static_cast<size_t>(v) * r.bone_slots + i] == bone)
            w += r.bone_weights[static_cast<size_t>(v) * r.bone_slots + i];
    return w;
}

TEST(SpineSkin, SkinBesideTheSpineFollowsItsBonesBySkinWeights) {
    const Trunk t = trunk(0.15, 0.10);
    ASSERT_TRUE(t.rig.sweeps[0].bends_smoothly) << "the trunk must be a thick chain";
    // The inner and outer reach: 0.45 and 0.8 of the median depth half-axis, 10 cm.
    Skin skin;
    skin.add({0, 0.02, 0.15}, 1, 0.7f, 2, 0.3f);  // 2 cm behind the middle bone: the bones alone
    skin.add({0, 0.0625, 0.15}, 1, 1.0f);         // half way between the reaches
    skin.add({0, 0.12, 0.15}, 1, 1.0f);           // beyond the outer reach: the sweep alone
    skin.add({0.02, 0, 0.15}, 3, 1.0f);           // near the spine, but skinned to the arm
    skin.add({0, -0.02, 0.15}, 1, 1.0f);          // 2 cm in front, 40 % on the arm's bone
    const int V = 5;
    const int32_t triangle[3] = {0, 1, 2};  // the fitting's mesh needs one; this step reads none
    const fit::FitMesh mesh(V, skin.positions.data(), 1, triangle);
    fit::RegionWeights r = on_the_sweep(V, {1.0f, 1.0f, 1.0f, 1.0f, 0.6f});
    EXPECT_EQ(fit::give_spine_skin_to_bones(mesh, t.rig, t.chains, t.chain_sweep, 2, skin.bones.data(),
                                            skin.weights.data(), r),
              3);

    EXPECT_FLOAT_EQ(r.sweep_weights[0], 0.0f);
    EXPECT_FLOAT_EQ(bone_weight(r, 0, 1), 0.7f);
    EXPECT_FLOAT_EQ(bone_weight(r, 0, 2), 0.3f);
    // Half way in distance, half way in the smoothstep.
    EXPECT_NEAR(r.sweep_weights[1], 0.5f, 0.02f);
    EXPECT_NEAR(bone_weight(r, 1, 1), 1.0f - r.sweep_weights[1], 1e-6f);
    EXPECT_FLOAT_EQ(r.sweep_weights[2], 1.0f);
    EXPECT_FLOAT_EQ(bone_weight(r, 2, 1), 0.0f);
    EXPECT_FLOAT_EQ(r.sweep_weights[3], 1.0f) << "no skin weight on the spine: the sweep keeps it";
    // Only the trunk's share moves; the arm's stays the arm's.
    EXPECT_FLOAT_EQ(r.sweep_weights[4], 0.0f);
    EXPECT_FLOAT_EQ(bone_weight(r, 4, 1), 0.6f);
    EXPECT_FLOAT_EQ(bone_weight(r, 4, 3), 0.4f);
    for (int v = 0; v < V; ++v) {
        float total = r.sweep_weights[v];
        for (int i = 0; i < r.bone_slots; ++i) total += r.bone_weights[static_cast<size_t>(v) * r.bone_slots + i];
        EXPECT_NEAR(total, 1.0f, 1e-6f) << "vertex " << v << " keeps its whole weight";
    }
}

TEST(SpineSkin, ALimbKeepsItsSkin) {
    // Half-axes of 1 cm on 10 cm links: an arm, not a trunk; its keys follow their bones.
    const Trunk t = trunk(0.01, 0.01);
    ASSERT_FALSE(t.rig.sweeps[0].bends_smoothly);
    Skin skin;
    for (double z : {0.14, 0.15, 0.16}) skin.add({0, 0.005, z}, 1, 1.0f);
    const int32_t triangle[3] = {0, 1, 2};
    const fit::FitMesh mesh(3, skin.positions.data(), 1, triangle);
    fit::RegionWeights r = on_the_sweep(3, {1.0f, 1.0f, 1.0f});
    EXPECT_EQ(fit::give_spine_skin_to_bones(mesh, t.rig, t.chains, t.chain_sweep, 2, skin.bones.data(),
                                            skin.weights.data(), r),
              0);
    for (int v = 0; v < 3; ++v) EXPECT_FLOAT_EQ(r.sweep_weights[v], 1.0f);
}

}  // namespace
}  // namespace sd
