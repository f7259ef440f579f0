// The shoulder (Sect. 3.5, Fig. 6): raising the arms must not drag the chest and back with
// the arm sweeps. A vertex of the trunk that no bone of the arm itself (upper arm and below)
// moves — skin on the spine, the neck or the clavicle — stays where linear blend skinning
// puts it, and the trunk's skin stays smooth (no fold where arm-bound skin swings up while
// the skin above stays with the torso).
#include "character_fit.h"
#include "dihedral.h"
#include "bind/bind.h"
#include "deform/deform.h"
#include "geometry/cross_section.h"
#include "fit/fit_rig.h"
#include "measure/measure.h"
#include "rig/key_pose.h"
#include "rig/sweep.h"

#include <sweepdeform_io/animation.h>
#include <sweepdeform_io/gltf_loader.h>

#include <glm/gtc/matrix_transform.hpp>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <map>
#include <memory>

namespace sd {
namespace {

std::string data_file(const std::string& name) { return std::string(SWEEPDEFORM_SHARED_DATA_DIR) + "/humans/" + name; }

using character_fit::character_input;
using character_fit::skeleton_of;

bool below(const Skeleton& s, int b, int root) {
    for (int x = b; x >= 0; x = s.parents[x])
        if (x == root) return true;
    return false;
}

/// Bone b's matrix of a pose (#B*16 floats, column-major), and back.
dmat4 pose_matrix(const std::vector<float>& pose, int b) {
    dmat4 m;
    for (int i = 0; i < 16; ++i) m[i / 4][i % 4] = pose[16 * b + i];
    return m;
}
void set_pose_matrix(std::vector<float>& pose, int b, const dmat4& m) {
    for (int i = 0; i < 16; ++i) pose[16 * b + i] = static_cast<float>(m[i / 4][i % 4]);
}

/// Turns the subtree of `bone` by `angle` about `axis` through the bone's head, on top of `pose`.
void turn_subtree(const Skeleton& s, std::vector<float>& pose, int bone, const dvec3& axis, double angle) {
    const dvec3 joint = dvec3(pose_matrix(pose, bone) * s.rest_inverse[bone] * dvec4(s.heads[bone], 1.0));
    const dmat4 turn =
        glm::translate(dmat4(1.0), joint) * glm::rotate(dmat4(1.0), angle, axis) * glm::translate(dmat4(1.0), -joint);
    for (int b = 0; b < s.bone_count(); ++b) {
        if (below(s, b, bone)) set_pose_matrix(pose, b, turn * pose_matrix(pose, b));
    }
}

/// The first swept link of every arm chain (the upper arms).
std::vector<int> upper_arms(const fit::FitResult& r) {
    std::vector<int> arms;
    for (const fit::Chain& ch : r.chains.chains)
        if (ch.kind == fit::ChainKind::Arm) arms.push_back(ch.bones[ch.first_swept]);
    return arms;
}

/// The axis about which a positive turn raises `arm` in the body's frontal plane.
dvec3 raising_axis(const Skeleton& s, int arm, const fit::BodyFrame& frame) {
    const dvec3 dir = glm::normalize(s.tails[arm] - s.heads[arm]);
    const dvec3 side = glm::normalize(dir - glm::dot(dir, frame.forward) * frame.forward);
    return glm::normalize(glm::cross(side, frame.up));
}

/// The triangles whose centre lies within 0.44 of an upper arm's length of its head.
std::vector<int32_t> triangles_near_shoulders(const io::Character& c, const Skeleton& s, const std::vector<int>& arms) {
    std::vector<int32_t> near;
    const int T = static_cast<int>(c.triangles.size() / 3);
    for (int t = 0; t < T; ++t) {
        dvec3 m(0.0);
        for (int i = 0; i < 3; ++i) {
            const int x = c.triangles[3 * t + i];
            m += dvec3(c.positions[3 * x], c.positions[3 * x + 1], c.positions[3 * x + 2]) / 3.0;
        }
        for (int a : arms)
            if (glm::length(m - s.heads[a]) < 0.44 * glm::length(s.tails[a] - s.heads[a])) {
                near.push_back(t);
                break;
            }
    }
    return near;
}

struct Figures {
    double trunk_max = 0.0;  ///< largest distance to linear blend skinning, trunk vertices
    double trunk_mean = 0.0;
    double dihedral_max = 0.0;  ///< largest change of a trunk edge's dihedral angle (radians)
    double dihedral_lbs = 0.0;  ///< the same with linear blend skinning
    int trunk = 0;
    double shoulder_width = 0.0;                          ///< distance between the shoulder joints
    double band_dihedral = 0.0, band_dihedral_lbs = 0.0;  ///< the same where the arm weighs < 0.5
    int64_t shoulder_pairs = 0, shoulder_pairs_lbs = 0;   ///< intersecting triangle pairs
};

void write_obj(const std::string& path, const io::Character& c, const std::vector<float>& pos) {
    std::FILE* f = std::fopen(path.c_str(), "w");
    if (!f) return;
    for (size_t i = 0; i < pos.size(); i += 3) std::fprintf(f, "v %.6f %.6f %.6f\n", pos[i], pos[i + 1], pos[i + 2]);
    for (size_t t = 0; t < c.triangles.size(); t += 3)
        std::fprintf(f, "f %d %d %d\n", c.triangles[t] + 1, c.triangles[t + 1] + 1, c.triangles[t + 2] + 1);
    std::fclose(f);
}

/// Fits, binds and poses `c` with both arms raised; returns the figures.
Figures raise_arms(const io::Character& c, const std::string& label, double degrees, double clavicle_degrees) {
    const Skeleton s = skeleton_of(c);
    const int V = static_cast<int>(c.positions.size() / 3);
    const fit::FitResult r = fit::fit_rig(character_input(c, s));
    Deformer d(r.rig, character_fit::bind_fitted(r, V, c.positions.data()));
    // Arm bones proper: the first swept link of every arm chain and everything below it.
    const std::vector<int> arm_roots = upper_arms(r);
    std::vector<int> clavicles;
    for (const fit::Chain& ch : r.chains.chains)
        if (ch.kind == fit::ChainKind::Arm && ch.first_swept > 0) clavicles.push_back(ch.bones[ch.first_swept - 1]);
    EXPECT_EQ(arm_roots.size(), 2u);
    std::vector<float> pose = io::rest_pose(c);
    {
        const dvec3 up = r.chains.frame.up;
        for (int clav : clavicles) {  // a small shrug: the clavicle's tip up
            const dvec3 dir = glm::normalize(s.tails[clav] - s.heads[clav]);
            const dvec3 axis = glm::normalize(glm::cross(dir, up));
            turn_subtree(s, pose, clav, axis, glm::radians(clavicle_degrees));
        }
        for (int arm : arm_roots)  // the upper arm up, in the body's frontal plane
            turn_subtree(s, pose, arm, raising_axis(s, arm, r.chains.frame), glm::radians(degrees));
    }
    std::vector<float> out(c.positions.size()), lbs(c.positions.size());
    d.deform(pose.data(), out.data());
    character_fit::skin_linearly(c, s, pose.data(), lbs.data());
    // The upper body (above 40 % of the way from the hips to the shoulders): the trunk has no
    // weight on the arm proper, the shoulder band less than half.
    double shoulder_z = 0.0, hip_z = 1e30;
    const dvec3 up = r.chains.frame.up;
    for (int arm : arm_roots) shoulder_z += glm::dot(s.heads[arm], up) / arm_roots.size();
    for (const fit::Chain& ch : r.chains.chains)
        if (ch.kind == fit::ChainKind::Leg) hip_z = std::min(hip_z, glm::dot(s.heads[ch.bones[0]], up));
    std::vector<char> trunk(V, 0), band(V, 0);
    Figures f;
    if (arm_roots.size() == 2) f.shoulder_width = glm::length(s.heads[arm_roots[0]] - s.heads[arm_roots[1]]);
    for (int v = 0; v < V; ++v) {
        double arm_weight = 0.0;
        for (int i = 0; i < 4; ++i)
            for (int a : arm_roots)
                if (below(s, c.skin_joints[4 * v + i], a)) arm_weight += c.skin_weights[4 * v + i];
        const dvec3 p(c.positions[3 * v], c.positions[3 * v + 1], c.positions[3 * v + 2]);
        const bool upper = glm::dot(p, up) > hip_z + 0.4 * (shoulder_z - hip_z);
        band[v] = upper && arm_weight < 0.5;
        trunk[v] = upper && arm_weight < 0.02;
        if (!trunk[v]) continue;
        ++f.trunk;
        const double e = glm::length(
            dvec3(out[3 * v] - lbs[3 * v], out[3 * v + 1] - lbs[3 * v + 1], out[3 * v + 2] - lbs[3 * v + 2]));
        f.trunk_max = std::max(f.trunk_max, e);
        f.trunk_mean += e;
    }
    f.trunk_mean /= std::max(1, f.trunk);
    f.dihedral_max = testing::max_dihedral_change(c, out, trunk);
    f.dihedral_lbs = testing::max_dihedral_change(c, lbs, trunk);
    f.band_dihedral = testing::max_dihedral_change(c, out, band);
    f.band_dihedral_lbs = testing::max_dihedral_change(c, lbs, band);
    // Intersecting triangle pairs near the shoulder joints (as the demo counts them).
    const std::vector<int32_t> near = triangles_near_shoulders(c, s, arm_roots);
    const int T = static_cast<int>(c.triangles.size() / 3);
    f.shoulder_pairs = measure::intersecting_pairs(V, out.data(), T, c.triangles.data(), near);
    f.shoulder_pairs_lbs = measure::intersecting_pairs(V, lbs.data(), T, c.triangles.data(), near);
    std::printf(
        "%s, arms up %.0f deg: %d trunk vertices, distance to skinning max %.3g (%.1f %% of the shoulder "
        "width) mean %.3g; largest dihedral change: trunk %.1f deg (skinning %.1f), shoulder band "
        "%.1f deg (skinning %.1f); intersecting pairs near the shoulders %lld (skinning %lld)\n",
        label.c_str(), degrees, f.trunk, f.trunk_max, 100.0 * f.trunk_max / f.shoulder_width, f.trunk_mean,
        glm::degrees(f.dihedral_max), glm::degrees(f.dihedral_lbs), glm::degrees(f.band_dihedral),
        glm::degrees(f.band_dihedral_lbs), static_cast<long long>(f.shoulder_pairs),
        static_cast<long long>(f.shoulder_pairs_lbs));
    if (const char* dir = std::getenv("SD_SHOULDER_DUMP")) {
        write_obj(std::string(dir) + "/" + label + "_sweep.obj", c, out);
        write_obj(std::string(dir) + "/" + label + "_lbs.obj", c, lbs);
        write_obj(std::string(dir) + "/" + label + "_rest.obj", c, c.positions);
    }
    return f;
}

/// Checks the figures of one character with its arms raised 110 degrees (and its clavicles
/// 12, as the demo's arms_up pose does).
void check_raised_arms(const io::Character& c, const std::string& label) {
    const Figures f = raise_arms(c, label, 110.0, 12.0);
    EXPECT_GT(f.trunk, 400);
    // The trunk stays with the torso and the clavicles: a few percent of the shoulder width
    // from linear blend skinning. Before inner links kept their skin weight, MakeHuman's chest
    // moved 3.9 cm (10 % of its shoulder width) with the arm sweeps; now 1.1 cm.
    EXPECT_LT(f.trunk_max, 0.05 * f.shoulder_width) << label;
    // No fold: the trunk's skin and the band where the arm weighs less than half crease less
    // than linear blend skinning's band (MakeHuman: trunk 18.7 degrees before inner links kept
    // their skin weight, 9.6 while the armpit's web joined the arm as points, 23.7 since it
    // joins as frames, skinning 8.6; band 40.9, 21.1 before the skin was handed over to the
    // upper arm beyond the arm's first plane, 29.2 as points, 30.5 as frames, skinning 45.4).
    // As points the trunk bent less, but seen from the side the raised arm met the chest along
    // a horizontal line, which no crease figure here showed (docs/quality.md, fourteenth
    // session): the trunk's 23.7 degrees are the side of the chest below the armpit rounding
    // with the arm.
    EXPECT_LT(f.dihedral_max, f.band_dihedral_lbs) << label;
    EXPECT_LT(f.band_dihedral, f.band_dihedral_lbs) << label;
    EXPECT_LE(f.shoulder_pairs, f.shoulder_pairs_lbs) << label;
}

TEST(Shoulder, RaisedArmsLeaveTheTrunkToTheTorso) {
    const std::string path = data_file("mh_male_game_engine.glb");
    if (!std::filesystem::exists(path)) GTEST_SKIP() << "../shared/data not found: skipped";
    check_raised_arms(io::load_gltf_character(path), "makehuman");
    // Any other glTF character, e.g. the built-in one exported from Blender (welded).
    if (const char* other = std::getenv("SD_SHOULDER_GLB")) {
        io::GltfLoadOptions load;
        load.weld = true;
        check_raised_arms(io::load_gltf_character(other, load), "given");
    }
}

/// How much the arm sweep's first two spans are squeezed along the sweep in `pose`: the least,
/// over u in (0, 1) of each span and every direction theta of its sections, of the sweep's
/// thickness along its normal, <dS/du, N>, at the key ellipses' boundary, over the same at rest.
double first_spans_least_thickness(const Sweep& s, const SkeletonPose& pose) {
    std::vector<dvec3> centers;
    std::vector<dquat> rotations;
    pose_keys(s, pose, centers, rotations);
    const SweepGeometry posed(centers, rotations);
    const auto thickness = [&](const SweepGeometry& g, int span, double u, double theta) {
        constexpr double h = 1e-4;
        const dvec3 d =
            sweep_point(g, s.rest_half_axes, span, u + h, theta) - sweep_point(g, s.rest_half_axes, span, u - h, theta);
        return glm::dot(d, g.normal(span, u)) / (2.0 * h);
    };
    double least = 1e30;
    for (int span = 0; span < 2; ++span)
        for (double u = 0.02; u < 0.99; u += 0.02)
            for (double theta = 0.0; theta < 6.28; theta += 0.05)
                least = std::min(least, thickness(posed, span, u, theta) / thickness(s.rest_geometry, span, u, theta));
    return least;
}

// The arm raised 160 degrees from the body's down in its frontal plane (skineval's
// shoulder_abd_160): the top of the shoulder is the inside of the bend. With the paper's
// shoulder key (half of the swing) the skin there folded into a lip where the arm meets the
// shoulder, its sharpest new crease 68.8 degrees (skinning: 171.6, a corner); with the
// shoulder key taking 0.6 and the next key 0.88 of the swing (set_shoulder_motions) the lip is
// flattened into a small corner in the pictures and the crease is 54.2 degrees; the inside of
// the arm's first spans keeps 0.70 of its rest thickness along the sweep (0.40 before).
TEST(Shoulder, TheTopOfAShoulderRaised160DegreesCreasesLessThanWithHalfTheSwing) {
    const std::string path = data_file("mh_male_game_engine.glb");
    if (!std::filesystem::exists(path)) GTEST_SKIP() << "../shared/data not found: skipped";
    const io::Character c = io::load_gltf_character(path);
    const Skeleton s = skeleton_of(c);
    const int V = static_cast<int>(c.positions.size() / 3);
    const fit::FitResult r = fit::fit_rig(character_input(c, s));
    Deformer d(r.rig, character_fit::bind_fitted(r, V, c.positions.data()));
    const dvec3 up = r.chains.frame.up;
    const std::vector<int> arms = upper_arms(r);
    ASSERT_EQ(arms.size(), 2u);
    std::vector<float> pose = io::rest_pose(c);
    std::vector<char> top(V, 0);
    std::vector<const Sweep*> sweeps;
    for (const int arm : arms) {
        for (const Sweep& sw : r.rig.sweeps)
            if (sw.keys.front().bone == arm) sweeps.push_back(&sw);
        const dvec3 dir = glm::normalize(s.tails[arm] - s.heads[arm]);
        const double rest = glm::degrees(std::acos(std::clamp(-glm::dot(dir, up), -1.0, 1.0)));
        turn_subtree(s, pose, arm, raising_axis(s, arm, r.chains.frame), glm::radians(160.0 - rest));
        // The skin above the joint, within half the upper arm's length of it.
        const double reach = 0.5 * glm::length(s.tails[arm] - s.heads[arm]);
        for (int v = 0; v < V; ++v) {
            const dvec3 p(c.positions[3 * v], c.positions[3 * v + 1], c.positions[3 * v + 2]);
            if (glm::length(p - s.heads[arm]) < reach && glm::dot(p - s.heads[arm], up) > 0.0) top[v] = 1;
        }
    }
    std::vector<float> out(c.positions.size()), lbs(c.positions.size());
    d.deform(pose.data(), out.data());
    character_fit::skin_linearly(c, s, pose.data(), lbs.data());
    const double sweep = glm::degrees(testing::max_dihedral_change(c, out, top));
    const double skinning = glm::degrees(testing::max_dihedral_change(c, lbs, top));
    std::printf("arms raised to 160 deg: sharpest new crease on top of the shoulders %.1f deg (skinning %.1f)\n", sweep,
                skinning);
    EXPECT_LT(sweep, 60.0);
    // Why: the inside of the arm's first spans, squeezed along the sweep (0.40 of its rest
    // thickness with half the swing at the shoulder key), bunched into the lip.
    ASSERT_EQ(sweeps.size(), 2u);
    SkeletonPose posed;
    posed.set(s, pose.data());
    for (const Sweep* sw : sweeps) {
        const double least = first_spans_least_thickness(*sw, posed);
        std::printf("the arm's first two spans keep at least %.3f of their rest thickness\n", least);
        EXPECT_GT(least, 0.6);
    }
}

/// `c` re-rested with both upper arms turned `degrees` up in the body's frontal plane (the
/// A-pose's 45 degrees down to a T-pose at 45): the mesh posed by its own skinning, the bones'
/// posed matrices its new rest.
io::Character rerested_with_arms_up(const io::Character& c, double degrees) {
    const Skeleton s = skeleton_of(c);
    const fit::FitResult r = fit::fit_rig(character_input(c, s));
    std::vector<float> pose = io::rest_pose(c);
    for (int arm : upper_arms(r))
        turn_subtree(s, pose, arm, raising_axis(s, arm, r.chains.frame), glm::radians(degrees));
    return character_fit::rerested(c, s, pose);
}

// A T-pose rest (many production and game rigs), its arms lowered 70 degrees, as skineval's
// shoulder_abd_20 does. The skin on top of the shoulder lies before the arm's first plane
// and follows the arm's first key; turning that key by half the swing, as the paper's joint
// keys do, left the top of the shoulder flat up to the joint and turned it down at a corner
// there (MakeHuman re-rested so in Blender: 14 intersecting pairs at the shoulder, Preserve
// Volume 7, skinning 22). The key takes the whole swing as the arm is lowered.
TEST(Shoulder, ArmsLoweredFromATPoseWrapTheTopOfTheShoulder) {
    const std::string path = data_file("mh_male_game_engine.glb");
    if (!std::filesystem::exists(path)) GTEST_SKIP() << "../shared/data not found: skipped";
    const io::Character c = rerested_with_arms_up(io::load_gltf_character(path), 45.0);
    const Skeleton s = skeleton_of(c);
    const int V = static_cast<int>(c.positions.size() / 3);
    const fit::FitResult r = fit::fit_rig(character_input(c, s));
    Deformer d(r.rig, character_fit::bind_fitted(c, r));
    const dvec3 up = r.chains.frame.up;
    std::vector<float> pose = io::rest_pose(c);
    const std::vector<int> arms = upper_arms(r);
    ASSERT_EQ(arms.size(), 2u);
    for (int arm : arms)  // down, in the frontal plane
        turn_subtree(s, pose, arm, raising_axis(s, arm, r.chains.frame), glm::radians(-70.0));
    std::vector<float> out(c.positions.size()), lbs(c.positions.size());
    d.deform(pose.data(), out.data());
    character_fit::skin_linearly(c, s, pose.data(), lbs.data());
    // The shoulders: skin within 0.44 of an upper arm's length of its head, and the top of
    // it (above the joint).
    std::vector<char> top(V, 0);
    const auto at = [&](int v) { return dvec3(c.positions[3 * v], c.positions[3 * v + 1], c.positions[3 * v + 2]); };
    for (int v = 0; v < V; ++v)
        for (int a : arms)
            if (glm::length(at(v) - s.heads[a]) < 0.44 * glm::length(s.tails[a] - s.heads[a]) &&
                glm::dot(at(v) - s.heads[a], up) > 0.0)
                top[v] = 1;
    const std::vector<int32_t> near = triangles_near_shoulders(c, s, arms);
    const int T = static_cast<int>(c.triangles.size() / 3);
    const int64_t pairs = measure::intersecting_pairs(V, out.data(), T, c.triangles.data(), near);
    const int64_t pairs_lbs = measure::intersecting_pairs(V, lbs.data(), T, c.triangles.data(), near);
    const double crease = testing::max_dihedral_change(c, out, top);
    const double crease_lbs = testing::max_dihedral_change(c, lbs, top);
    std::printf(
        "MakeHuman in a T-pose, arms lowered 70 deg: intersecting pairs near the shoulders %lld (skinning "
        "%lld); largest dihedral change on top of the shoulders %.1f deg (skinning %.1f)\n",
        static_cast<long long>(pairs), static_cast<long long>(pairs_lbs), glm::degrees(crease),
        glm::degrees(crease_lbs));
    EXPECT_LE(pairs, pairs_lbs / 2);
    EXPECT_LT(crease, crease_lbs);
}

/// The armpit of MakeHuman's 13K male, fitted and bound by the product (skipped without ../shared/data).
class Armpit : public ::testing::Test {
protected:
    void SetUp() override {
        const std::string path = data_file("mh_male_game_engine.glb");
        if (!std::filesystem::exists(path)) GTEST_SKIP() << "../shared/data not found: skipped";
        fitted = character_fit::fit_and_bind(io::load_gltf_character(path));
        V = static_cast<int>(c.positions.size() / 3);
    }
    character_fit::Fitted fitted;
    const io::Character& c = fitted.character;
    const Skeleton& s = fitted.skeleton;
    const fit::FitResult& r = fitted.fit;
    const std::unique_ptr<Deformer>& d = fitted.deformer;
    int V = 0;
};

/// The area of the loop around `center` cut by the plane (center, normal) from the triangles
/// `tris` of the mesh at `pos` (0 if no loop surrounds it).
double section_area(const std::vector<float>& pos, const std::vector<int32_t>& tris, const dvec3& center,
                    const dvec3& normal) {
    const fit::FitMesh mesh(static_cast<int>(pos.size() / 3), pos.data(), static_cast<int>(tris.size() / 3),
                            tris.data());
    const fit::PlaneFrame plane(center, normal, glm::abs(normal.x) < 0.9 ? dvec3(1, 0, 0) : dvec3(0, 1, 0));
    std::vector<std::vector<dvec2>> polygons;
    for (const fit::SectionLoop& loop : fit::cut_mesh(mesh, center, normal)) {
        polygons.emplace_back();
        for (const fit::SectionPoint& p : loop.points) polygons.back().push_back(plane.to_plane(p.p));
    }
    const fit::LoopPick pick = fit::pick_loop(polygons, dvec2(0.0), 0.0);
    return pick.loop >= 0 && pick.contains ? std::abs(fit::polygon_area(polygons[pick.loop])) : 0.0;
}

// The armpit at 160 degrees of abduction (issue 14): skin shared by the trunk and a raised arm
// is blended as frames. When the arm's influences joined it as points, the upper arm's own
// skin beside the armpit cut the chord as linear blend skinning does: its cross-section a
// fifth down the upper arm kept 0.88 of its area (skinning 0.88, Preserve Volume 1.0,
// skineval's shoulder_abd_160 on this body).
TEST_F(Armpit, TheArmsOwnSkinKeepsItsSectionAt160Degrees) {
    const dvec3 up = r.chains.frame.up, fwd = r.chains.frame.forward;
    std::vector<float> pose = io::rest_pose(c);
    const std::vector<int> arms = upper_arms(r);
    ASSERT_EQ(arms.size(), 2u);
    for (int arm : arms) {  // each upper arm raised to 160 degrees from hanging, in the frontal plane
        const dvec3 dir = glm::normalize(s.tails[arm] - s.heads[arm]);
        const dvec3 side = glm::normalize(dir - glm::dot(dir, fwd) * fwd);
        const double rest = std::acos(std::clamp(glm::dot(side, -up), -1.0, 1.0));
        turn_subtree(s, pose, arm, raising_axis(s, arm, r.chains.frame), glm::radians(160.0) - rest);
    }
    std::vector<float> out(c.positions.size()), lbs(c.positions.size());
    d->deform(pose.data(), out.data());
    character_fit::skin_linearly(c, s, pose.data(), lbs.data());
    const auto posed = [&](int bone, const dvec3& p) {
        return dvec3(pose_matrix(pose, bone) * s.rest_inverse[bone] * dvec4(p, 1.0));
    };
    for (int arm : arms) {
        // As the instrument slices: the triangles whose vertices the arm's bones dominate.
        std::vector<char> dominated(V, 0);
        for (int v = 0; v < V; ++v) {
            int best = 0;
            for (int i = 1; i < 4; ++i)
                if (c.skin_weights[4 * v + i] > c.skin_weights[4 * v + best]) best = i;
            dominated[v] = below(s, c.skin_joints[4 * v + best], arm);
        }
        std::vector<int32_t> tris;
        for (size_t t = 0; t + 2 < c.triangles.size(); t += 3)
            if (dominated[c.triangles[t]] && dominated[c.triangles[t + 1]] && dominated[c.triangles[t + 2]])
                tris.insert(tris.end(), {c.triangles[t], c.triangles[t + 1], c.triangles[t + 2]});
        const dvec3 h = s.heads[arm], t = s.tails[arm];
        const dvec3 at = h + 0.2 * (t - h), at_posed = posed(arm, at);
        const double rest = section_area(c.positions, tris, at, glm::normalize(t - h));
        const dvec3 n_posed = glm::normalize(posed(arm, t) - posed(arm, h));
        const double sweep = section_area(out, tris, at_posed, n_posed) / rest;
        const double skinned = section_area(lbs, tris, at_posed, n_posed) / rest;
        std::printf("MakeHuman, arm raised to 160 deg: upper arm's section a fifth down %.3f of rest (skinning %.3f)\n",
                    sweep, skinned);
        EXPECT_GT(rest, 0.0);
        EXPECT_GE(sweep, 0.9);
    }
}

// The same web under a rigid turn of the whole body: every vertex and its local map J turn
// rigidly.
TEST_F(Armpit, TheWebTurnsRigidlyWithTheBody) {
    const dmat4 turn = glm::translate(dmat4(1.0), dvec3(0.3, -0.2, 0.1)) *
                       glm::rotate(dmat4(1.0), glm::radians(70.0), glm::normalize(dvec3(1.0, 2.0, 0.5)));
    std::vector<float> pose = io::rest_pose(c);
    for (int b = 0; b < s.bone_count(); ++b) set_pose_matrix(pose, b, turn * pose_matrix(pose, b));
    std::vector<float> out(c.positions.size()), frames(9 * static_cast<size_t>(V));
    d->deform_frames(pose.data(), out.data(), frames.data());
    double worst_position = 0.0, worst_map = 0.0;
    for (int v = 0; v < V; ++v) {
        const dvec3 x(c.positions[3 * v], c.positions[3 * v + 1], c.positions[3 * v + 2]);
        const dvec3 expected = dvec3(turn * dvec4(x, 1.0));
        worst_position =
            std::max(worst_position, glm::length(dvec3(out[3 * v], out[3 * v + 1], out[3 * v + 2]) - expected));
        for (int row = 0; row < 3; ++row)
            for (int col = 0; col < 3; ++col)
                worst_map = std::max(worst_map,
                                     std::abs(frames[3 * (static_cast<size_t>(row) * V + v) + col] - turn[col][row]));
    }
    std::printf("MakeHuman turned rigidly: worst vertex %.2e m, worst entry of J %.2e\n", worst_position, worst_map);
    EXPECT_LT(worst_position, 1e-5);
    EXPECT_LT(worst_map, 1e-5);
}

}  // namespace
}  // namespace sd
