#include "rig/key_pose.h"

#include "rig/key_correction.h"

#include <algorithm>
#include <cmath>

namespace sd {

void swing_twist(const dquat& r, const dvec3& axis, dquat* swing, dquat* twist) {
    const dvec3 v(r.x, r.y, r.z);
    const dvec3 p = glm::dot(v, axis) * axis;
    dquat t(r.w, p.x, p.y, p.z);
    const double n = glm::length(t);
    // A pure 180° swing has no defined twist; take none.
    t = n > 1e-12 ? t / n : dquat(1, 0, 0, 0);
    *twist = t;
    *swing = r * glm::conjugate(t);
}

/// Fraction f of a rotation (slerp from identity along the short arc).
static dquat fraction_of(const dquat& r, double f) {
    const dquat q = r.w < 0.0 ? -r : r;
    return glm::slerp(dquat(1, 0, 0, 0), q, f);
}

void pose_keys(const Sweep& sweep, const SkeletonPose& pose, std::vector<dvec3>& centers,
               std::vector<dquat>& rotations) {
    const int K = sweep.key_count();
    centers.resize(K);
    rotations.resize(K);
    for (int k = 0; k < K; ++k) {
        const KeyEllipse& e = sweep.keys[k];
        const KeyMotion& m = sweep.motions[k];
        if (!m.blend.empty()) {
            // The bones' motions blended as dual quaternions about the key's center: each
            // bone moves it by deform * c - c and turns it by its rotation. A linear blend of
            // the moves cut the chord between bones turned by different angles, so a bent
            // trunk's sections fell back towards the spine and pushed the lower back out
            // (MakeHuman's skin 1.34x its rest distance from the spine at spine_bend_45; 1.28x
            // blended so).
            // (The center as rest + the blended move, so the rest pose gives it back exactly.)
            dquat real(0, 0, 0, 0), dual(0, 0, 0, 0);
            const dquat& first = pose.rotation[m.blend.front().first];
            for (const auto& [bone, w] : m.blend) {
                const dquat& r = pose.rotation[bone];
                const double sw = glm::dot(r, first) < 0.0 ? -w : w;
                const dvec3 t = dvec3(pose.deform[bone] * dvec4(e.center, 1.0)) - e.center;
                real += sw * r;
                dual += (0.5 * sw) * (dquat(0.0, t.x, t.y, t.z) * r);
            }
            const double n = glm::length(real);
            const dquat moved = (2.0 / (n * n)) * (dual * glm::conjugate(real));
            centers[k] = e.center + dvec3(moved.x, moved.y, moved.z);
            rotations[k] = glm::normalize((real / n) * e.orientation);
            continue;
        }
        if (m.from_bone == m.to_bone) {
            centers[k] = dvec3(pose.deform[e.bone] * dvec4(e.center, 1.0));
            rotations[k] = pose.rotation[e.bone] * e.orientation;
            continue;
        }
        const dquat& from = pose.rotation[m.from_bone];
        const dquat relative = glm::conjugate(from) * pose.rotation[m.to_bone];
        dquat swing, twist;
        swing_twist(relative, m.axis, &swing, &twist);
        rotations[k] = glm::normalize(from * fraction_of(swing, shoulder_swing_share(m, swing)) *
                                      fraction_of(twist, m.twist_share) * e.orientation);
        if (m.turns_about_pivot) {
            const dvec3 pivot(pose.deform[e.bone] * dvec4(m.pivot, 1.0));
            centers[k] = pivot + glm::mat3_cast(rotations[k] * glm::conjugate(e.orientation)) * (e.center - m.pivot);
        } else {
            centers[k] = dvec3(pose.deform[e.bone] * dvec4(e.center, 1.0));
        }
    }
}

double joint_angle(const KeyJoint& joint, const SkeletonPose& pose) {
    if (joint.parent < 0) return 0.0;
    return angle_between(pose.rotation[joint.parent] * joint.parent_axis,
                         pose.rotation[joint.child] * joint.child_axis);
}

void correct_keys(const Sweep& sweep, const SkeletonPose& pose, std::vector<dvec3>& centers,
                  std::vector<dquat>& rotations, std::vector<double>& a, std::vector<double>& b,
                  std::vector<double>* angles) {
    const int K = sweep.key_count();
    if (angles) angles->resize(K);
    for (int k = 0; k < K; ++k) {
        const KeyJoint& j = sweep.joints[k];
        const bool corrected = !sweep.keys[k].corrections.empty();
        if (!corrected && !angles) continue;
        const double angle = joint_angle(j, pose);
        if (angles) (*angles)[k] = angle;
        if (corrected)
            apply_correction(correction_at(sweep.keys[k].corrections, j.rest_angle, angle), centers[k], rotations[k],
                             a[k], b[k]);
    }
}

}  // namespace sd
