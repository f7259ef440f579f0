#include "deform/joint_volume.h"

#include "deform/deform.h"

#include <glm/gtc/type_ptr.hpp>

#include <algorithm>
#include <cmath>
#include <string>

namespace sd {

namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kSwingStep = kPi / 4.0;  // the table's bends: 45°, 90°, 135°
// Growth at the joint's keys reaches the mesh in part (skin shared with the torso follows the
// leg's sweep in part); the measured share is trusted within these bounds, else the joint is
// left alone.
constexpr double kLeastGain = 0.2, kMostGain = 5.0;
// At most this share of the sweep's rest volume is added: a larger loss is where the limb meets
// the body, which growing the limb makes up for only by swelling it (CesiumMan's arm lowered to
// 20° loses a quarter of the arm's volume at the armpit; a lowered arm now adds nothing at all,
// kLoweredWithoutGrowth). 0.05 until the twenty-fourth session, which cut short the broad
// body's hip at 90°: its leg loses about 6 % there (region volume -1.08 %, now -0.84 %).
constexpr double kMostAdded = 0.1;
// A joint whose bends lose less than this share of its sweep's volume gets no table.
constexpr double kLeastLost = 1e-3;

dvec3 perpendicular(const dvec3& axis) {
    const dvec3 a = glm::abs(axis);
    const dvec3 ref = a.x <= a.y && a.x <= a.z ? dvec3(1, 0, 0) : (a.y <= a.z ? dvec3(0, 1, 0) : dvec3(0, 0, 1));
    return glm::normalize(glm::cross(axis, ref));
}

// The share of a table's reading kept where the link's rest direction `axis` is swung to
// `swung`: all of it, unless `lowering` is given and the swing lowers the link towards it.
double share_kept(const dvec3& axis, const dvec3& swung, const dvec3& lowering) {
    if (lowering == dvec3(0.0)) return 1.0;
    return 1.0 - std::clamp(glm::dot(swung - axis, lowering) / kLoweredWithoutGrowth, 0.0, 1.0);
}

bool in_subtree(const Skeleton& s, int bone, int root) {
    for (int b = bone; b >= 0; b = s.parents[b])
        if (b == root) return true;
    return false;
}

// Posed bone matrices with the subtree of `child` turned by r about `pivot`, the rest elsewhere.
void bent_pose(const Skeleton& s, int child, const dquat& r, const dvec3& pivot, std::vector<float>& out) {
    const dmat4 turn = glm::translate(dmat4(1.0), pivot) * glm::mat4_cast(r) * glm::translate(dmat4(1.0), -pivot);
    out.resize(16 * static_cast<size_t>(s.bone_count()));
    for (int b = 0; b < s.bone_count(); ++b) {
        const dmat4 m = in_subtree(s, b, child) ? turn * s.rest[b] : s.rest[b];
        const double* v = glm::value_ptr(m);
        for (int i = 0; i < 16; ++i) out[16 * static_cast<size_t>(b) + i] = static_cast<float>(v[i]);
    }
}

}  // namespace

VolumeControlKeys JointVolumeTable::keys(int key_count) const {
    VolumeControlKeys k;
    k.joints = {key};
    for (int n : {key - 1, key + 1, key - 2, key + 2})
        if (n >= 0 && n < key_count) k.neighbours.push_back(n);
    return k;
}

dvec3 JointVolumeTable::swung_axis(const SkeletonPose& pose) const {
    return (glm::conjugate(pose.rotation[parent]) * pose.rotation[child]) * axis;
}

void JointVolumeTable::swing(const dvec3& d, double* bend, double* direction) const {
    *bend = std::acos(std::clamp(glm::dot(d, axis), -1.0, 1.0));
    *direction = std::atan2(glm::dot(d, e2), glm::dot(d, e1));
}

double JointVolumeTable::added_volume(const SkeletonPose& pose, const dvec3& lowering) const {
    if (added.empty()) return 0.0;
    const dvec3 swung = swung_axis(pose);
    const double kept = share_kept(axis, swung, lowering);
    if (!(kept > 0.0)) return 0.0;
    double bend = 0.0, direction = 0.0;
    swing(swung, &bend, &direction);
    // Around the axis, the trigonometric polynomial through a row's 8 samples (exact for
    // harmonics up to the third): what the mesh loses goes round a joint like a sine, from a
    // loss one way to a gain the other (MakeHuman's hip at 70°: +1.3 L to -1.2 L), and lines
    // between samples 45° apart missed its zero by 0.1 L.
    const auto at = [&](int i) {
        const double* f = &added[static_cast<size_t>(i) * kDirections];
        double v = 0.0;
        for (int j = 0; j < kDirections; ++j) {
            const double d = direction - 2.0 * kPi * j / kDirections;
            double w = 1.0;  // the Dirichlet kernel of 8 points, the Nyquist term halved
            for (int k = 1; k < kDirections / 2; ++k) w += 2.0 * std::cos(k * d);
            w += std::cos(kDirections / 2 * d);
            v += f[j] * w / kDirections;
        }
        return v;
    };
    const double s = bend / kSwingStep;  // 1 at the first row
    double v = 0.0;
    if (s <= 1.0) {
        v = s * at(0);  // from nothing at no bend, whatever the direction
    } else {
        const double t = std::min(s, static_cast<double>(kSwings)) - 1.0;
        const int i0 = std::min(static_cast<int>(t), kSwings - 2);
        const double f = t - i0;
        v = (1.0 - f) * at(i0) + f * at(i0 + 1);
    }
    return kept * std::clamp(v, 0.0, most_added);
}

double cone_volume(const float* p, const std::vector<int32_t>& triangles, const dvec3& apex) {
    double v = 0.0;
    for (size_t t = 0; t + 2 < triangles.size(); t += 3) {
        dvec3 c[3];
        for (int k = 0; k < 3; ++k) {
            const float* q = p + 3 * static_cast<size_t>(triangles[t + k]);
            c[k] = dvec3(q[0], q[1], q[2]) - apex;
        }
        v += glm::dot(c[0], glm::cross(c[1], c[2]));
    }
    return v / 6.0;
}

std::vector<JointVolumeTable> measure_joint_volumes(Deformer& deformer, int32_t triangle_count,
                                                    const int32_t* triangles) {
    const int V = deformer.vertex_count();
    if (triangle_count < 0 || (triangle_count > 0 && !triangles))
        throw InvalidInput("the triangles are missing or their count is negative");
    for (int64_t i = 0; i < 3 * static_cast<int64_t>(triangle_count); ++i)
        if (triangles[i] < 0 || triangles[i] >= V)
            throw InvalidInput("triangle corner " + std::to_string(i) + " is not a vertex index (0.." +
                               std::to_string(V - 1) + ")");

    const auto guard = deformer.lock();
    const Rig& rig = deformer.rig();
    const Skeleton& sk = rig.skeleton;
    const bool enabled = deformer.volume_enabled();
    const double strength = deformer.volume_strength();
    const std::vector<double> offsets = deformer.volume_offsets();
    const std::vector<JointVolumeTable> kept = deformer.joint_volumes();
    struct Restore {  // the deformer's settings as they were, also if a deform throws
        Deformer& d;
        bool enabled;
        double strength;
        const std::vector<double>& offsets;
        const std::vector<JointVolumeTable>& tables;
        ~Restore() {
            d.set_volume_preservation(enabled, strength);
            d.set_volume_offsets(offsets);
            d.set_joint_volumes(tables);
        }
    } restore{deformer, enabled, strength, offsets, kept};
    deformer.set_volume_preservation(true, 1.0);
    const std::vector<double> no_offsets(rig.sweeps.size(), 0.0);
    deformer.set_volume_offsets(no_offsets);
    deformer.set_joint_volumes({});

    // The whole mesh: where a bent limb loses volume (its fold, the skin it shares with the
    // torso) is not known beforehand, and cones from the joint see no change where the skin
    // stays put or turns about the joint.
    const std::vector<int32_t> body(triangles, triangles + 3 * static_cast<size_t>(triangle_count));
    std::vector<float> pose, rest(3 * static_cast<size_t>(V)), posed(rest.size());
    bent_pose(sk, 0, dquat(1, 0, 0, 0), dvec3(0.0), pose);
    deformer.deform(pose.data(), rest.data());

    std::vector<JointVolumeTable> tables;
    for (size_t si = 0; si < rig.sweeps.size(); ++si) {
        const Sweep& s = rig.sweeps[si];
        if (s.bends_smoothly) continue;  // a torso's keys follow blends of bones, not one joint
        for (int k = 0; k < s.key_count(); ++k) {
            const KeyEllipse& e = s.keys[k];
            if (!e.is_joint_key() || e.joint_parent == e.bone) continue;
            const bool seen = std::any_of(tables.begin(), tables.end(), [&](const JointVolumeTable& t) {
                return t.parent == e.joint_parent && t.child == e.bone;
            });
            // The lower link's direction: to the next joint's bone (a twist about the bone is then
            // no bend: MakeHuman's neck twisted about its bone read 20° off the sweep's axis as
            // a bend, and grew). At the sweep's end, as the sweep runs there: a glTF rig's last
            // bones point any way (CesiumMan's head and feet +x).
            int next = -1;
            for (int j = k + 1; j < s.key_count() && next < 0; ++j)
                if (s.keys[j].is_joint_key() && s.keys[j].joint_parent == e.bone) next = j;
            dvec3 along = next >= 0 ? sk.heads[s.keys[next].bone] - sk.heads[e.bone] : dvec3(0.0);
            if (!(glm::length(along) > 0.0))
                along = k + 1 < s.key_count() ? s.keys[k + 1].center - e.center : e.center - s.keys[k - 1].center;
            if (seen || !(glm::length(along) > 0.0)) continue;
            JointVolumeTable t;
            t.sweep = static_cast<int>(si);
            t.key = k;
            t.parent = e.joint_parent;
            t.child = e.bone;
            t.axis = glm::normalize(along);
            t.e1 = perpendicular(t.axis);
            t.e2 = glm::cross(t.axis, t.e1);
            const dvec3 pivot = sk.heads[e.bone];
            // (A mesh mirrored in its data is wound the other way: its volumes come out negative.)
            const double signed_rest = cone_volume(rest.data(), body, pivot);
            const double sign = signed_rest < 0.0 ? -1.0 : 1.0;
            const double v_rest = sign * signed_rest;

            std::vector<double> lost(JointVolumeTable::kSwings * JointVolumeTable::kDirections);
            std::vector<dquat> turns(lost.size());
            for (int i = 0; i < JointVolumeTable::kSwings; ++i)
                for (int j = 0; j < JointVolumeTable::kDirections; ++j) {
                    const double phi = 2.0 * kPi * j / JointVolumeTable::kDirections;
                    const dvec3 towards = std::cos(phi) * t.e1 + std::sin(phi) * t.e2;
                    const size_t n = static_cast<size_t>(i) * JointVolumeTable::kDirections + j;
                    turns[n] = glm::angleAxis((i + 1) * kSwingStep, glm::normalize(glm::cross(t.axis, towards)));
                    bent_pose(sk, e.bone, turns[n], pivot, pose);
                    deformer.deform(pose.data(), posed.data());
                    // (Swings the reading gives nothing at, an arm lowered, are no loss to
                    // make up: the growth's share is not probed there, nor read beside them.)
                    lost[n] = share_kept(t.axis, turns[n] * t.axis, s.motions[k].lowering) *
                              (v_rest - sign * cone_volume(posed.data(), body, pivot));
                }
            // How much of a growth at the joint's keys reaches the mesh: once, where the most is lost.
            const size_t worst = static_cast<size_t>(std::max_element(lost.begin(), lost.end()) - lost.begin());
            if (!(lost[worst] > kLeastLost * s.rest_volume)) continue;  // nothing worth holding
            // (A table that reads `probe` at every swing, grown where the final one will be.)
            const double probe = std::min(lost[worst], kMostAdded * s.rest_volume);
            JointVolumeTable probing = t;
            probing.added.assign(lost.size(), probe);
            probing.most_added = probe;
            deformer.set_joint_volumes({probing});
            bent_pose(sk, e.bone, turns[worst], pivot, pose);
            deformer.deform(pose.data(), posed.data());
            deformer.set_joint_volumes({});
            const double lost_raised = v_rest - sign * cone_volume(posed.data(), body, pivot);
            const double gain = (lost[worst] - lost_raised) / probe;
            if (!(gain >= kLeastGain)) continue;
            t.added.resize(lost.size());
            for (size_t n = 0; n < lost.size(); ++n)
                t.added[n] = std::clamp(lost[n] / std::min(gain, kMostGain), -s.rest_volume, s.rest_volume);
            t.most_added = kMostAdded * s.rest_volume;
            tables.push_back(std::move(t));
        }
    }
    return tables;
}

}  // namespace sd
