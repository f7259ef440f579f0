// Which bones the limb sweeps run along (fit/chains.h), on stick humanoids whose answer is known
// by construction: a T-pose with a short clavicle in line with the arm, limb bones cut in two,
// an arm straight at the elbow, and twist bones hung beside the links; and how the skinned
// bones are read as one tree when they hang from bones without skin (fit/deform_hierarchy.h).
#include "fit/chains.h"
#include "fit/deform_hierarchy.h"

#include <gtest/gtest.h>

#include <glm/gtc/matrix_transform.hpp>

#include <string>
#include <vector>

namespace sd {
namespace {

/// A stick humanoid in metres, facing -y, in a T-pose: bones added by name from head to tail.
struct StickBody {
    std::vector<std::string> names;
    std::vector<int> parents;
    std::vector<dvec3> heads, tails;

    int add(const std::string& name, const std::string& parent, const dvec3& head, const dvec3& tail) {
        names.push_back(name);
        parents.push_back(parent.empty() ? -1 : index(parent));
        heads.push_back(head);
        tails.push_back(tail);
        return static_cast<int>(names.size()) - 1;
    }
    int index(const std::string& name) const {
        for (size_t i = 0; i < names.size(); ++i)
            if (names[i] == name) return static_cast<int>(i);
        ADD_FAILURE() << "no bone " << name;
        return -1;
    }
    /// The bone cut in two at its middle: NAME keeps the first half, NAME.001 the second and
    /// the bone's children.
    void cut(const std::string& name) {
        const int b = index(name);
        const dvec3 mid = 0.5 * (heads[b] + tails[b]);
        const int half = add(name + ".001", name, mid, tails[b]);
        for (size_t i = 0; i < parents.size(); ++i)
            if (parents[i] == b && static_cast<int>(i) != half) parents[i] = half;
        tails[b] = mid;
    }
    Skeleton skeleton() const {
        std::vector<dmat4> rest;
        for (const dvec3& h : heads) rest.push_back(glm::translate(dmat4(1.0), h));
        return Skeleton::build(parents, rest, heads, tails);
    }
    std::vector<std::string> chain(const fit::ChainSet& set, const std::string& chain_name, std::string* end) const {
        for (const fit::Chain& c : set.chains)
            if (c.name == chain_name) {
                std::vector<std::string> out;
                for (int b : c.bones) out.push_back(names[b]);
                *end = c.end_bone >= 0 ? names[c.end_bone] : "";
                return out;
            }
        ADD_FAILURE() << "no chain " << chain_name;
        return {};
    }
    std::vector<std::string> links(const fit::ChainSet& set, const std::string& chain_name) const {
        for (const fit::Chain& c : set.chains)
            if (c.name == chain_name) {
                std::vector<std::string> out;
                for (int b : c.links()) out.push_back(names[b]);
                return out;
            }
        return {};
    }
};

/// Hips at 1 m, a spine of three bones, neck and head; legs with feet and toes; arms straight
/// out sideways from a clavicle `clavicle` long in line with them, hands with three fingers.
StickBody t_pose(double clavicle) {
    StickBody b;
    b.add("hips", "", {0, 0, 1.0}, {0, 0, 1.1});
    b.add("spine", "hips", {0, 0, 1.1}, {0, 0, 1.25});
    b.add("chest", "spine", {0, 0, 1.25}, {0, 0, 1.42});
    b.add("neck", "chest", {0, 0, 1.42}, {0, 0, 1.52});
    b.add("head", "neck", {0, 0, 1.52}, {0, 0, 1.72});
    for (const auto& [side, x] : {std::pair<std::string, double>{"_l", 1.0}, {"_r", -1.0}}) {
        const double s0 = 0.03, s1 = s0 + clavicle;
        b.add("clavicle" + side, "chest", {x * s0, 0, 1.4}, {x * s1, 0, 1.4});
        b.add("upperarm" + side, "clavicle" + side, {x * s1, 0, 1.4}, {x * (s1 + 0.29), 0, 1.4});
        b.add("forearm" + side, "upperarm" + side, {x * (s1 + 0.29), 0, 1.4}, {x * (s1 + 0.55), 0, 1.4});
        b.add("hand" + side, "forearm" + side, {x * (s1 + 0.55), 0, 1.4}, {x * (s1 + 0.63), 0, 1.4});
        for (int f = 0; f < 3; ++f)
            b.add("finger" + std::to_string(f) + side, "hand" + side, {x * (s1 + 0.63), 0.02 * (f - 1), 1.4},
                  {x * (s1 + 0.71), 0.02 * (f - 1), 1.4});
        b.add("thigh" + side, "hips", {x * 0.1, 0, 1.0}, {x * 0.1, 0, 0.55});
        b.add("shin" + side, "thigh" + side, {x * 0.1, 0, 0.55}, {x * 0.1, 0, 0.1});
        b.add("foot" + side, "shin" + side, {x * 0.1, 0, 0.1}, {x * 0.1, -0.12, 0.02});
        b.add("toe" + side, "foot" + side, {x * 0.1, -0.12, 0.02}, {x * 0.1, -0.18, 0.02});
    }
    return b;
}

fit::ChainSet chains_of(const StickBody& b) { return fit::find_chains(b.skeleton(), b.names, {}); }

TEST(Chains, AStickBodyHasTheExpectedLimbs) {
    const StickBody b = t_pose(0.15);
    const fit::ChainSet set = chains_of(b);
    std::string end;
    EXPECT_EQ(b.chain(set, "arm_l", &end), (std::vector<std::string>{"clavicle_l", "upperarm_l", "forearm_l"}));
    EXPECT_EQ(end, "hand_l");
    EXPECT_EQ(b.chain(set, "leg_r", &end), (std::vector<std::string>{"thigh_r", "shin_r"}));
    EXPECT_EQ(end, "foot_r");
}

// A T-posed arm straight at the elbow from a short clavicle in line with it: every joint of
// the arm continues the last, and still the clavicle is no piece of the upper arm (its length
// is unlike the upper arm's) and the elbow stays (upper arm and forearm together are most of
// the limb).
TEST(Chains, AShortClavicleInLineWithAStraightArmIsNotTheArm) {
    const StickBody b = t_pose(0.08);
    const fit::ChainSet set = chains_of(b);
    std::string end;
    EXPECT_EQ(b.chain(set, "arm_l", &end), (std::vector<std::string>{"clavicle_l", "upperarm_l", "forearm_l"}));
    EXPECT_EQ(b.links(set, "arm_l"), (std::vector<std::string>{"upperarm_l", "forearm_l"}));
    EXPECT_EQ(end, "hand_l");
}

// Limb bones cut in two (Rigify's DEF-upper_arm.L / .001): each cut segment is one link,
// also with the elbow straight, and the clavicle stays out.
TEST(Chains, LimbBonesCutInTwoAreOneLinkEach) {
    StickBody b = t_pose(0.15);
    for (const char* bone : {"upperarm_l", "forearm_l", "thigh_l", "shin_l", "upperarm_r", "forearm_r"}) b.cut(bone);
    const fit::ChainSet set = chains_of(b);
    std::string end;
    EXPECT_EQ(b.chain(set, "arm_l", &end),
              (std::vector<std::string>{"clavicle_l", "upperarm_l", "upperarm_l.001", "forearm_l", "forearm_l.001"}));
    EXPECT_EQ(b.links(set, "arm_l"), (std::vector<std::string>{"upperarm_l", "forearm_l"}));
    EXPECT_EQ(end, "hand_l");
    EXPECT_EQ(b.chain(set, "leg_l", &end),
              (std::vector<std::string>{"thigh_l", "thigh_l.001", "shin_l", "shin_l.001"}));
    EXPECT_EQ(b.links(set, "leg_l"), (std::vector<std::string>{"thigh_l", "shin_l"}));
    EXPECT_EQ(end, "foot_l");
    EXPECT_EQ(b.links(set, "leg_r"), (std::vector<std::string>{"thigh_r", "shin_r"}));  // uncut
}

// A twist bone hung beside the shin over its lower half (Unreal's calf_twist_01_l) is longer
// than the foot and its toe together, but the foot reaches farther: the leg runs on to it.
TEST(Chains, ATwistBoneBesideTheShinIsPassedBy) {
    StickBody b = t_pose(0.15);
    for (const auto& [side, x] : {std::pair<std::string, double>{"_l", 1.0}, {"_r", -1.0}})
        b.add("shin_twist" + side, "shin" + side, {x * 0.1, 0, 0.32}, {x * 0.1, 0, 0.1});
    const fit::ChainSet set = chains_of(b);
    std::string end;
    EXPECT_EQ(b.chain(set, "leg_l", &end), (std::vector<std::string>{"thigh_l", "shin_l"}));
    EXPECT_EQ(end, "foot_l");
}

// 3ds Max Biped's hierarchy: the thighs hang from the first spine bone, the clavicles from the
// neck (at its head). The skinned pelvis above the hips is the torso's first link, and the neck,
// which carries little skin, stays the neck; the chains are the plain body's.
TEST(Chains, ABipedHierarchyHasThePlainBodysChains) {
    StickBody b = t_pose(0.15);
    for (const char* side : {"_l", "_r"}) {
        const std::string s(side);
        b.parents[b.index("thigh" + s)] = b.index("spine");
        b.parents[b.index("clavicle" + s)] = b.index("neck");
    }
    std::vector<double> mass(b.names.size(), 1.0);
    mass[b.index("neck")] = 0.2;
    const fit::ChainSet set = fit::find_chains(b.skeleton(), b.names, mass);
    std::string end;
    EXPECT_EQ(b.chain(set, "torso", &end), (std::vector<std::string>{"hips", "spine", "chest"}));
    EXPECT_EQ(end, "neck");
    EXPECT_EQ(b.chain(set, "neck", &end), (std::vector<std::string>{"neck"}));
    EXPECT_EQ(end, "head");
    EXPECT_EQ(b.chain(set, "arm_l", &end), (std::vector<std::string>{"clavicle_l", "upperarm_l", "forearm_l"}));
    EXPECT_EQ(b.chain(set, "leg_r", &end), (std::vector<std::string>{"thigh_r", "shin_r"}));
    // A skinned bone above the hips with its head on the hips' head (a centre-of-gravity bone)
    // is no link: it would have no length.
    StickBody cog = b;
    cog.add("cog", "", {0, 0, 1.0}, {0, 0.1, 1.0});
    cog.parents[cog.index("hips")] = cog.index("cog");
    std::vector<double> cog_mass = mass;
    cog_mass.push_back(1.0);
    EXPECT_EQ(cog.chain(fit::find_chains(cog.skeleton(), cog.names, cog_mass), "torso", &end),
              (std::vector<std::string>{"hips", "spine", "chest"}));
    // A neck carrying as much skin as the chest is a chest (a rig without a neck bone whose
    // arms start at the chest's head): the torso runs on to the head.
    mass[b.index("neck")] = 1.0;
    EXPECT_EQ(b.chain(fit::find_chains(b.skeleton(), b.names, mass), "torso", &end),
              (std::vector<std::string>{"hips", "spine", "chest", "neck"}));
}

/// Per bone of `b`: skin weight 1, but 0 for the bones named in `unskinned`.
std::vector<double> masses(const StickBody& b, const std::vector<std::string>& unskinned) {
    std::vector<double> m(b.names.size(), 1.0);
    for (const std::string& n : unskinned) m[b.index(n)] = 0.0;
    return m;
}

std::string parent_name(const StickBody& b, const Skeleton& s, const std::string& bone) {
    const int p = s.parents[b.index(bone)];
    return p >= 0 ? b.names[p] : "";
}

/// The T-pose stick body rigged as Rigify rigs one: a root bone at the floor holds the hips and
/// a mechanism bone where the hips lie (ORG-hips); the thighs hang from ORG-hips, the
/// clavicles from ORG-chest (where the chest lies, under ORG-hips), the upper arms from
/// ORG-clavicle_l/_r (where the clavicles lie). With `placed` false the mechanism bones lie
/// elsewhere (a rig whose controls are not where the deform bones are).
StickBody mechanism_rig(bool placed) {
    StickBody b = t_pose(0.15);
    const auto at = [&](const std::string& bone, const dvec3& away) {
        const int i = b.index(bone);
        return std::pair<dvec3, dvec3>{b.heads[i] + (placed ? dvec3(0.0) : away),
                                       b.tails[i] + (placed ? dvec3(0.0) : away)};
    };
    b.add("root", "", {0, 0, 0}, {0, 0.2, 0});
    b.parents[b.index("hips")] = b.index("root");
    const dvec3 behind(0, 0.5, 0);
    auto [hh, ht] = at("hips", behind);
    b.add("ORG-hips", "root", hh, ht);
    auto [ch, ct] = at("chest", behind);
    b.add("ORG-chest", "ORG-hips", ch, ct);
    for (const char* side : {"_l", "_r"}) {
        const std::string s(side);
        b.parents[b.index("thigh" + s)] = b.index("ORG-hips");
        b.parents[b.index("clavicle" + s)] = b.index("ORG-chest");
        auto [kh, kt] = at("clavicle" + s, behind);
        b.add("ORG-clavicle" + s, "ORG-chest", kh, kt);
        b.parents[b.index("upperarm" + s)] = b.index("ORG-clavicle" + s);
    }
    return b;
}

const std::vector<std::string> kMechanism = {"root", "ORG-hips", "ORG-chest", "ORG-clavicle_l", "ORG-clavicle_r"};

// Skinned bones that form one tree are read as they are.
TEST(DeformHierarchy, OneTreeIsKept) {
    const StickBody b = t_pose(0.15);
    const Skeleton s = b.skeleton();
    std::vector<std::string> notes;
    EXPECT_EQ(fit::deform_hierarchy(s, masses(b, {}), b.names, &notes).parents, s.parents);
    EXPECT_TRUE(notes.empty());
}

// Rigify's mechanism bones lie where the deform bones do: each deform root hangs from the
// skinned bone in the place of its parent, and the chains are the plain body's.
TEST(DeformHierarchy, RootsHangWhereTheirMechanismParentsLie) {
    const StickBody b = mechanism_rig(true);
    std::vector<std::string> notes;
    const std::vector<double> m = masses(b, kMechanism);
    const Skeleton s = fit::deform_hierarchy(b.skeleton(), m, b.names, &notes);
    EXPECT_EQ(parent_name(b, s, "thigh_l"), "hips");
    EXPECT_EQ(parent_name(b, s, "clavicle_r"), "chest");
    EXPECT_EQ(parent_name(b, s, "upperarm_l"), "clavicle_l");
    EXPECT_EQ(parent_name(b, s, "hips"), "root");  // the highest tree stays where it was
    EXPECT_EQ(notes.size(), 6u);
    // As the hierarchy was given, no chain could be found.
    EXPECT_THROW(fit::find_chains(b.skeleton(), b.names, m), InvalidInput);
    const fit::ChainSet set = fit::find_chains(s, b.names, m);
    std::string end;
    EXPECT_EQ(b.chain(set, "arm_l", &end), (std::vector<std::string>{"clavicle_l", "upperarm_l", "forearm_l"}));
    EXPECT_EQ(end, "hand_l");
    EXPECT_EQ(b.chain(set, "leg_r", &end), (std::vector<std::string>{"thigh_r", "shin_r"}));
    EXPECT_EQ(end, "foot_r");
}

// Where no mechanism bone lies in a skinned bone's place, each deform root hangs from the
// skinned bone nearest its head, nearest first: the clavicle from the chest (its head 3 cm
// from the chest, 3.6 cm from the neck), then the upper arm from the clavicle just hung.
TEST(DeformHierarchy, RootsHangFromTheNearestSkinnedBone) {
    const StickBody b = mechanism_rig(false);
    const std::vector<double> m = masses(b, kMechanism);
    const Skeleton s = fit::deform_hierarchy(b.skeleton(), m, b.names, nullptr);
    EXPECT_EQ(parent_name(b, s, "thigh_r"), "hips");
    EXPECT_EQ(parent_name(b, s, "clavicle_l"), "chest");
    EXPECT_EQ(parent_name(b, s, "upperarm_r"), "clavicle_r");
    std::string end;
    EXPECT_EQ(b.chain(fit::find_chains(s, b.names, m), "arm_r", &end),
              (std::vector<std::string>{"clavicle_r", "upperarm_r", "forearm_r"}));
}

// A skinned bone far from the body (a prop across the scene) is left where it is.
TEST(DeformHierarchy, ABoneApartFromTheBodyStaysApart) {
    StickBody b = t_pose(0.15);
    b.add("prop", "", {3, 0, 1}, {3, 0, 1.5});
    const Skeleton s = fit::deform_hierarchy(b.skeleton(), masses(b, {}), b.names, nullptr);
    EXPECT_EQ(parent_name(b, s, "prop"), "");
}

}  // namespace
}  // namespace sd
