#include "anatomy/joint.h"

#include <glm/gtc/matrix_transform.hpp>

#include <algorithm>
#include <cmath>
#include <string>

namespace sd::anatomy {

double Joint::ellipse_radius(const dvec3& d) const {
    const dmat3 frame = glm::mat3_cast(key_ellipse.orientation);
    const double x = glm::dot(d, frame[0]), y = glm::dot(d, frame[1]);
    const double len = std::hypot(x, y);
    if (!(len > 1e-12)) return std::min(key_ellipse.a, key_ellipse.b);
    const double c = x / len, s = y / len;
    return 1.0 / std::sqrt((c / key_ellipse.a) * (c / key_ellipse.a) + (s / key_ellipse.b) * (s / key_ellipse.b));
}

Joint make_joint(const Rig& rig, int lower_bone, JointKind kind, const dvec3* flexion_direction) {
    const Skeleton& sk = rig.skeleton;
    if (lower_bone < 0 || lower_bone >= sk.bone_count())
        throw InvalidInput("bone " + std::to_string(lower_bone) + " is out of range");
    Joint j;
    j.kind = kind;
    for (int s = 0; s < static_cast<int>(rig.sweeps.size()) && j.sweep < 0; ++s)
        for (int k = 0; k < rig.sweeps[s].key_count(); ++k) {
            const KeyEllipse& e = rig.sweeps[s].keys[k];
            if (e.bone == lower_bone && e.is_joint_key()) {
                j.sweep = s;
                j.key = k;
                break;
            }
        }
    if (j.sweep < 0)
        throw InvalidInput("no sweep has a joint key ellipse whose lower link is bone " + std::to_string(lower_bone));
    const Sweep& sw = rig.sweeps[j.sweep];
    j.key_ellipse = sw.keys[j.key];
    j.upper_bone = j.key_ellipse.joint_parent;
    j.lower_bone = lower_bone;
    j.center = j.key_ellipse.center;
    const auto dir = [&](int b, double* length) {
        const dvec3 d = sk.tails[b] - sk.heads[b];
        *length = glm::length(d);
        return d / *length;
    };
    j.upper_dir = dir(j.upper_bone, &j.upper_length);
    j.lower_dir = dir(j.lower_bone, &j.lower_length);
    // A link reaches at least from the key before (the shoulder, the hip) to the key after (the
    // wrist, the ankle): a limb bone cut in two (Rigify's DEF-forearm.L / .001) is one link of
    // the sweep, and its first bone only half of it, which halved the collision region. (At
    // least: a glTF rig's estimated tails may reach past the next joint, and its regions stay.)
    const auto reach_to_key = [&](int from, int step, double* length) {
        for (int k = from; k >= 0 && k < sw.key_count(); k += step)
            if (sw.keys[k].is_joint_key() || k == 0 || k == sw.key_count() - 1) {
                *length = std::max(*length, glm::length(sw.keys[k].center - j.center));
                return;
            }
    };
    reach_to_key(j.key - 1, -1, &j.upper_length);
    reach_to_key(j.key + 1, +1, &j.lower_length);
    if (flexion_direction) {
        const dvec3 f = *flexion_direction - glm::dot(*flexion_direction, j.upper_dir) * j.upper_dir;
        if (!(glm::length(f) > 1e-6 * glm::length(*flexion_direction)) || !std::isfinite(glm::length(f)))
            throw InvalidInput("the flexion direction is parallel to the upper link (or not finite)");
        j.flexion_dir = glm::normalize(f);
        j.rest_bend = std::atan2(glm::dot(j.lower_dir, j.flexion_dir), glm::dot(j.lower_dir, j.upper_dir));
    } else if (kind != JointKind::Generic) {
        throw InvalidInput("an elbow or a knee needs its flexion direction");
    }
    // The collision region: far enough along both links for the contact of a deep bend
    // (two limbs of radius r at an opening angle phi overlap up to r / sin(phi/2) from the
    // joint: ~3.9 r at 150 degrees), within the shorter link; around a generic joint (armpit,
    // groin, neck) 1.6 times its key ellipse's larger half-axis.
    const double r = std::max(j.key_ellipse.a, j.key_ellipse.b);
    j.auto_region_radius =
        kind == JointKind::Generic ? 1.6 * r : std::min(0.7 * std::min(j.upper_length, j.lower_length), 5.0 * r);
    j.region_radius = j.auto_region_radius;
    return j;
}

JointPose pose_joint(const Joint& j, const SkeletonPose& pose) {
    JointPose p;
    p.rest_center = j.center;
    p.upper = pose.deform[j.upper_bone];
    p.lower = pose.deform[j.lower_bone];
    p.center = dvec3(p.lower * dvec4(j.center, 1.0));
    const dquat ru = pose.rotation[j.upper_bone], rl = pose.rotation[j.lower_bone];
    p.relative = glm::normalize(glm::conjugate(ru) * rl);
    const dvec3 du = ru * j.upper_dir, dl = rl * j.lower_dir;
    p.bend = std::acos(std::clamp(glm::dot(du, dl), -1.0, 1.0));
    if (j.has_flexion_direction()) {
        const dvec3 f = ru * j.flexion_dir;
        p.flexion = std::atan2(glm::dot(dl, f), glm::dot(dl, du)) - j.rest_bend;
    } else {
        p.flexion = p.bend - std::acos(std::clamp(glm::dot(j.upper_dir, j.lower_dir), -1.0, 1.0));
    }
    return p;
}

dmat4 JointPose::fractional(double f) const {
    const dquat q = relative.w < 0.0 ? -relative : relative;
    const dquat part = glm::slerp(dquat(1, 0, 0, 0), q, f);
    return upper * glm::translate(dmat4(1.0), rest_center) * glm::mat4_cast(part) *
           glm::translate(dmat4(1.0), -rest_center);
}

}  // namespace sd::anatomy
