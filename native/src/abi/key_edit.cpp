// The C ABI of key-ellipse editing (sweepdeform.h, "key-ellipse editing", Sect. 4.2): the
// corrections of key ellipses over their joint angle. No exception leaves this file.
#include "sweepdeform/sweepdeform.h"

#include "abi/guard.h"
#include "deform/deform.h"
#include "rig/bent_joint_trajectory.h"
#include "rig/key_pose.h"
#include "rig/rig.h"
#include "rig/twisted_trajectory.h"

#include <array>
#include <cmath>
#include <memory>
#include <string>
#include <vector>

namespace {

using sd::abi::fail;
using sd::abi::guarded;
using sd::abi::sweep_of;

const sd::KeyEllipse& key_of(const sd_rig* rig, int32_t sweep, int32_t key) {
    const sd::Sweep& s = sweep_of(rig, sweep);
    SD_REQUIRE(key >= 0 && key < s.key_count(),
               "key index " + std::to_string(key) + " is out of range for sweep " + std::to_string(sweep));
    return s.keys[key];
}

sd::KeyCorrection correction_from(float angle, const float* values, int32_t muted) {
    SD_REQUIRE(values, "values is NULL");
    sd::KeyCorrection c;
    c.angle = angle;
    c.delta_center = sd::dvec3(values[0], values[1], values[2]);
    c.delta_rotation = sd::dvec3(values[3], values[4], values[5]);
    c.scale_a = values[6];
    c.scale_b = values[7];
    c.muted = muted != 0;
    return c;
}

void write_values(const sd::KeyCorrectionValue& v, float* values) {
    const double d[8] = {v.delta_center.x,   v.delta_center.y,   v.delta_center.z, v.delta_rotation.x,
                         v.delta_rotation.y, v.delta_rotation.z, v.scale_a,        v.scale_b};
    for (int i = 0; i < 8; ++i) values[i] = static_cast<float>(d[i]);
}

void write_correction(const sd::KeyCorrection& c, int i, float* angles, float* values, int32_t* muted) {
    if (angles) angles[i] = static_cast<float>(c.angle);
    if (values) {
        sd::KeyCorrectionValue v;
        v.delta_center = c.delta_center;
        v.delta_rotation = c.delta_rotation;
        v.scale_a = c.scale_a;
        v.scale_b = c.scale_b;
        write_values(v, values + 8 * i);
    }
    if (muted) muted[i] = c.muted ? 1 : 0;
}

std::vector<sd::CorrectionRecord> records_from(int32_t count, const int32_t* sweeps, const int32_t* keys,
                                               const float* angles, const float* values, const int32_t* muted) {
    SD_REQUIRE(count >= 0 && count <= 10'000'000, "count is out of range");
    SD_REQUIRE(count == 0 || (sweeps && keys && angles && values), "a correction array is NULL");
    std::vector<sd::CorrectionRecord> records(count);
    for (int i = 0; i < count; ++i) {
        records[i].sweep = sweeps[i];
        records[i].key = keys[i];
        records[i].correction = correction_from(angles[i], values + 8 * i, muted ? muted[i] : 0);
    }
    return records;
}

/// The pose of the call (#B*16 column-major), or the rest pose for NULL.
sd::SkeletonPose pose_of(const sd::Rig& rig, int32_t bone_count, const float* pose) {
    sd::SkeletonPose p;
    if (!pose) {
        p.set_rest(rig.skeleton);
        return p;
    }
    if (bone_count != rig.skeleton.bone_count())
        throw sd::InvalidInput("pose has " + std::to_string(bone_count) + " bones, the rig " +
                               std::to_string(rig.skeleton.bone_count()));
    p.set(rig.skeleton, pose);
    return p;
}

}  // namespace

extern "C" {

sd_status sd_rig_key_joint(const sd_rig* rig, int32_t sweep, int32_t key, int32_t* parent_bone, int32_t* child_bone,
                           float* rest_angle) {
    return guarded(__func__, [&] {
        key_of(rig, sweep, key);
        const sd::KeyJoint& j = rig->rig.sweeps[sweep].joints[key];
        if (parent_bone) *parent_bone = j.parent;
        if (child_bone) *child_bone = j.child;
        if (rest_angle) *rest_angle = static_cast<float>(j.rest_angle);
        return SD_OK;
    });
}

sd_status sd_rig_key_joint_angle(const sd_rig* rig, int32_t sweep, int32_t key, int32_t bone_count, const float* pose,
                                 float* out_angle) {
    return guarded(__func__, [&] {
        key_of(rig, sweep, key);
        SD_REQUIRE(out_angle, "out_angle is NULL");
        const sd::SkeletonPose p = pose_of(rig->rig, bone_count, pose);
        *out_angle = static_cast<float>(sd::joint_angle(rig->rig.sweeps[sweep].joints[key], p));
        return SD_OK;
    });
}

sd_status sd_rig_set_key_correction(sd_rig* rig, int32_t sweep, int32_t key, float angle, const float* values,
                                    int32_t muted, int32_t* out_index) {
    return guarded(__func__, [&] {
        const sd::KeyEllipse& e = key_of(rig, sweep, key);
        const sd::KeyCorrection c = correction_from(angle, values, muted);
        std::vector<sd::KeyCorrection> list = e.corrections;
        bool replaced = false;
        for (sd::KeyCorrection& old : list)
            if (std::abs(old.angle - c.angle) <= sd::kCorrectionAngleTolerance) {
                old = c;
                replaced = true;
                break;
            }
        if (!replaced) list.push_back(c);
        rig->rig.set_key_corrections(sweep, key, std::move(list));
        if (out_index) {
            const auto& now = rig->rig.sweeps[sweep].keys[key].corrections;
            for (size_t i = 0; i < now.size(); ++i)
                if (now[i].angle == c.angle) *out_index = static_cast<int32_t>(i);
        }
        return SD_OK;
    });
}

sd_status sd_rig_remove_key_correction(sd_rig* rig, int32_t sweep, int32_t key, int32_t index) {
    return guarded(__func__, [&] {
        const sd::KeyEllipse& e = key_of(rig, sweep, key);
        SD_REQUIRE(index >= 0 && index < static_cast<int32_t>(e.corrections.size()),
                   "correction index " + std::to_string(index) + " is out of range");
        std::vector<sd::KeyCorrection> list = e.corrections;
        list.erase(list.begin() + index);
        rig->rig.set_key_corrections(sweep, key, std::move(list));
        return SD_OK;
    });
}

sd_status sd_rig_mute_key_correction(sd_rig* rig, int32_t sweep, int32_t key, int32_t index, int32_t muted) {
    return guarded(__func__, [&] {
        const sd::KeyEllipse& e = key_of(rig, sweep, key);
        SD_REQUIRE(index >= 0 && index < static_cast<int32_t>(e.corrections.size()),
                   "correction index " + std::to_string(index) + " is out of range");
        std::vector<sd::KeyCorrection> list = e.corrections;
        list[index].muted = muted != 0;
        rig->rig.set_key_corrections(sweep, key, std::move(list));
        return SD_OK;
    });
}

int32_t sd_rig_key_correction_count(const sd_rig* rig, int32_t sweep, int32_t key) {
    int32_t count = -1;
    guarded(__func__, [&] {
        count = static_cast<int32_t>(key_of(rig, sweep, key).corrections.size());
        return SD_OK;
    });
    return count;
}

sd_status sd_rig_get_key_corrections(const sd_rig* rig, int32_t sweep, int32_t key, int32_t count, float* angles,
                                     float* values, int32_t* muted) {
    return guarded(__func__, [&] {
        const sd::KeyEllipse& e = key_of(rig, sweep, key);
        if (count != static_cast<int32_t>(e.corrections.size()))
            return fail(SD_ERR_MISMATCH, "count " + std::to_string(count) + " differs from the key's " +
                                             std::to_string(e.corrections.size()) + " corrections");
        for (int i = 0; i < count; ++i) write_correction(e.corrections[i], i, angles, values, muted);
        return SD_OK;
    });
}

sd_status sd_rig_key_correction_at(const sd_rig* rig, int32_t sweep, int32_t key, float angle, float* values) {
    return guarded(__func__, [&] {
        const sd::KeyEllipse& e = key_of(rig, sweep, key);
        SD_REQUIRE(values, "values is NULL");
        SD_REQUIRE(std::isfinite(angle), "angle is not finite");
        write_values(sd::correction_at(e.corrections, rig->rig.sweeps[sweep].joints[key].rest_angle, angle), values);
        return SD_OK;
    });
}

int32_t sd_rig_correction_count(const sd_rig* rig) {
    if (!rig) return -1;
    int32_t n = 0;
    for (const sd::Sweep& s : rig->rig.sweeps)
        for (const sd::KeyEllipse& e : s.keys) n += static_cast<int32_t>(e.corrections.size());
    return n;
}

sd_status sd_rig_get_corrections(const sd_rig* rig, int32_t count, int32_t* sweeps, int32_t* keys, float* angles,
                                 float* values, int32_t* muted) {
    return guarded(__func__, [&] {
        SD_REQUIRE(rig, "rig is NULL");
        const std::vector<sd::CorrectionRecord> all = rig->rig.corrections();
        if (count != static_cast<int32_t>(all.size()))
            return fail(SD_ERR_MISMATCH, "count " + std::to_string(count) + " differs from the rig's " +
                                             std::to_string(all.size()) + " corrections");
        for (int i = 0; i < count; ++i) {
            if (sweeps) sweeps[i] = all[i].sweep;
            if (keys) keys[i] = all[i].key;
            write_correction(all[i].correction, i, angles, values, muted);
        }
        return SD_OK;
    });
}

sd_status sd_rig_set_corrections(sd_rig* rig, int32_t count, const int32_t* sweeps, const int32_t* keys,
                                 const float* angles, const float* values, const int32_t* muted) {
    return guarded(__func__, [&] {
        SD_REQUIRE(rig, "rig is NULL");
        rig->rig.set_corrections(records_from(count, sweeps, keys, angles, values, muted));
        return SD_OK;
    });
}

sd_status sd_rig_pose_keys(const sd_rig* rig, int32_t sweep, int32_t bone_count, const float* pose, int32_t corrected,
                           int32_t key_count, float* centers, float* orientations, float* half_axes, float* angles) {
    return guarded(__func__, [&] {
        const sd::Sweep& s = sweep_of(rig, sweep);
        if (key_count != s.key_count())
            return fail(SD_ERR_MISMATCH, "key_count " + std::to_string(key_count) + " differs from the sweep's " +
                                             std::to_string(s.key_count()));
        const sd::SkeletonPose p = pose_of(rig->rig, bone_count, pose);
        std::vector<sd::dvec3> c;
        std::vector<sd::dquat> q;
        std::vector<double> a = s.rest_half_axes.a, b = s.rest_half_axes.b, angle;
        sd::pose_keys(s, p, c, q);
        if (corrected) {
            sd::correct_keys(s, p, c, q, a, b, &angle);
        } else {
            angle.resize(s.key_count());
            for (int k = 0; k < s.key_count(); ++k) angle[k] = sd::joint_angle(s.joints[k], p);
        }
        for (int k = 0; k < s.key_count(); ++k) {
            for (int i = 0; i < 3 && centers; ++i) centers[3 * k + i] = static_cast<float>(c[k][i]);
            if (orientations) {
                const double w[4] = {q[k].w, q[k].x, q[k].y, q[k].z};
                for (int i = 0; i < 4; ++i) orientations[4 * k + i] = static_cast<float>(w[i]);
            }
            if (half_axes) {
                half_axes[2 * k] = static_cast<float>(a[k]);
                half_axes[2 * k + 1] = static_cast<float>(b[k]);
            }
            if (angles) angles[k] = static_cast<float>(angle[k]);
        }
        return SD_OK;
    });
}

sd_status sd_rig_evaluate_posed_sweep(const sd_rig* rig, int32_t sweep, int32_t bone_count, const float* pose,
                                      int32_t count, const float* u, float* centers, float* rotations,
                                      float* half_axes) {
    return guarded(__func__, [&] {
        const sd::Sweep& s = sweep_of(rig, sweep);
        SD_REQUIRE(count >= 0 && count <= 100'000'000, "count is out of range");
        SD_REQUIRE(u || count == 0, "u is NULL");
        for (int i = 0; i < count; ++i)
            SD_REQUIRE(std::isfinite(u[i]) && u[i] >= 0.0f && u[i] <= 1.0f,
                       "u[" + std::to_string(i) + "] is not in [0, 1]");
        const sd::SkeletonPose p = pose_of(rig->rig, bone_count, pose);
        std::vector<sd::dvec3> c;
        std::vector<sd::dquat> q;
        sd::HalfAxisFunctions h = s.rest_half_axes;
        sd::pose_keys(s, p, c, q);
        if (s.has_corrections) sd::correct_keys(s, p, c, q, h.a, h.b);
        const sd::SweepGeometry g = sd::posed_geometry(s, c, q);
        // The trajectory the deformer gives the skin (a twisted limb's turns with its twist).
        const std::vector<std::array<sd::CubicSpan, 2>> twisted = sd::twisted_trajectory(s, g);
        for (int i = 0; i < count; ++i) {
            int span;
            double uu;
            sd::split_parameter(g.span_count(), u[i], &span, &uu);
            const sd::dvec3 ci = twisted.empty() ? g.center(span, uu) : twisted[span][uu < 0.5 ? 0 : 1].value(uu);
            const sd::dmat3 r = g.rotation(span, uu);
            const sd::dvec2 ab = h.at(span, uu);
            for (int j = 0; centers && j < 3; ++j) centers[3 * i + j] = static_cast<float>(ci[j]);
            for (int j = 0; rotations && j < 9; ++j) rotations[9 * i + j] = static_cast<float>(r[j / 3][j % 3]);
            if (half_axes) {
                half_axes[2 * i] = static_cast<float>(ab.x);
                half_axes[2 * i + 1] = static_cast<float>(ab.y);
            }
        }
        return SD_OK;
    });
}

sd_status sd_deformer_set_rig_corrections(sd_deformer* d, int32_t count, const int32_t* sweeps, const int32_t* keys,
                                          const float* angles, const float* values, const int32_t* muted) {
    return guarded(__func__, [&] {
        SD_REQUIRE(d, "deformer is NULL");
        d->deformer->set_corrections(records_from(count, sweeps, keys, angles, values, muted));
        return SD_OK;
    });
}

}  // extern "C"
