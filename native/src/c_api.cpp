// The C ABI: validation, status codes, the thread-local error message. No exception
// leaves this file.
#include "sweepdeform/sweepdeform.h"

#include "bind.h"
#include "deform.h"
#include "key_pose.h"
#include "rig.h"
#include "serialize.h"
#include "c_api_util.h"

#include <cmath>
#include <memory>
#include <new>
#include <string>


namespace {

using sd::abi::fail;
using sd::abi::guarded;

std::vector<sd::KeyEllipse> keys_from_arrays(int32_t K, const float* centers, const float* orientations,
                                             const float* half_axes, const int32_t* bones,
                                             const int32_t* joint_parents, const float* fractions) {
    SD_REQUIRE(K >= 2 && K <= 256, "key_count must be in 2..256");
    SD_REQUIRE(centers && orientations && half_axes && bones && joint_parents && fractions,
               "a key ellipse array is NULL");
    std::vector<sd::KeyEllipse> keys(K);
    for (int k = 0; k < K; ++k) {
        sd::KeyEllipse& e = keys[k];
        e.center = sd::dvec3(centers[3 * k], centers[3 * k + 1], centers[3 * k + 2]);
        e.orientation = sd::dquat(orientations[4 * k], orientations[4 * k + 1],
                                  orientations[4 * k + 2], orientations[4 * k + 3]);
        // Float input is unit only to ~1e-7: accept |q| within 1e-3 of 1, then normalise.
        const double qn = std::sqrt(glm::dot(e.orientation, e.orientation));
        if (!std::isfinite(qn) || std::abs(qn - 1.0) > 1e-3)
            throw sd::InvalidInput("key ellipse " + std::to_string(k) +
                                   ": orientation is not a unit quaternion (|q| = " +
                                   std::to_string(qn) + ")");
        e.orientation /= qn;
        e.a = half_axes[2 * k];
        e.b = half_axes[2 * k + 1];
        e.bone = bones[k];
        e.joint_parent = joint_parents[k];
        e.swing_fraction = fractions[2 * k];
        e.twist_fraction = fractions[2 * k + 1];
    }
    return keys;
}

sd_status write_blob(const std::vector<uint8_t>& blob, uint8_t* buffer, int64_t capacity,
                     int64_t* out_size) {
    SD_REQUIRE(out_size, "out_size is NULL");
    *out_size = static_cast<int64_t>(blob.size());
    if (!buffer) return SD_OK;
    if (capacity < static_cast<int64_t>(blob.size()))
        return fail(SD_ERR_INVALID_ARGUMENT, "buffer capacity " + std::to_string(capacity) +
                                                 " is smaller than the blob (" +
                                                 std::to_string(blob.size()) + " bytes)");
    std::copy(blob.begin(), blob.end(), buffer);
    return SD_OK;
}

const sd::Sweep& sweep_of(const sd_rig* rig, int32_t sweep) {
    SD_REQUIRE(rig, "rig is NULL");
    SD_REQUIRE(sweep >= 0 && sweep < static_cast<int32_t>(rig->rig.sweeps.size()),
               "sweep index " + std::to_string(sweep) + " is out of range");
    return rig->rig.sweeps[sweep];
}

// ---- key-ellipse editing helpers ----

const sd::KeyEllipse& key_of(const sd_rig* rig, int32_t sweep, int32_t key) {
    const sd::Sweep& s = sweep_of(rig, sweep);
    SD_REQUIRE(key >= 0 && key < s.key_count(), "key index " + std::to_string(key) +
                                                    " is out of range for sweep " + std::to_string(sweep));
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
    const double d[8] = {v.delta_center.x, v.delta_center.y, v.delta_center.z, v.delta_rotation.x,
                         v.delta_rotation.y, v.delta_rotation.z, v.scale_a, v.scale_b};
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
                                               const float* angles, const float* values,
                                               const int32_t* muted) {
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

int32_t sd_abi_version(void) { return SD_ABI_VERSION; }
const char* sd_library_version(void) { return SWEEPDEFORM_VERSION; }
const char* sd_last_error(void) { return sd::abi::last_error().c_str(); }

sd_status sd_rig_create(int32_t bone_count, const int32_t* parents, const float* rest,
                        const float* heads, const float* tails, sd_rig** out_rig) {
    return guarded(__func__, [&] {
        SD_REQUIRE(out_rig, "out_rig is NULL");
        auto rig = std::make_unique<sd_rig>();
        rig->rig.skeleton = sd::Skeleton::from_arrays(bone_count, parents, rest, heads, tails);
        *out_rig = rig.release();
        return SD_OK;
    });
}

void sd_rig_destroy(sd_rig* rig) { delete rig; }

sd_status sd_rig_clone(const sd_rig* rig, sd_rig** out_rig) {
    return guarded(__func__, [&] {
        SD_REQUIRE(rig && out_rig, "rig or out_rig is NULL");
        *out_rig = new sd_rig(*rig);
        return SD_OK;
    });
}

sd_status sd_rig_add_sweep(sd_rig* rig, int32_t key_count, const float* centers,
                           const float* orientations, const float* half_axes,
                           const int32_t* bones, const int32_t* joint_parents,
                           const float* fractions, int32_t* out_sweep_index) {
    return guarded(__func__, [&] {
        SD_REQUIRE(rig, "rig is NULL");
        const int index = rig->rig.add_sweep(keys_from_arrays(
            key_count, centers, orientations, half_axes, bones, joint_parents, fractions));
        if (out_sweep_index) *out_sweep_index = index;
        return SD_OK;
    });
}

int32_t sd_rig_bone_count(const sd_rig* rig) { return rig ? rig->rig.skeleton.bone_count() : -1; }
int32_t sd_rig_sweep_count(const sd_rig* rig) {
    return rig ? static_cast<int32_t>(rig->rig.sweeps.size()) : -1;
}

int32_t sd_rig_key_count(const sd_rig* rig, int32_t sweep) {
    int32_t count = -1;
    guarded(__func__, [&] {
        count = sweep_of(rig, sweep).key_count();
        return SD_OK;
    });
    return count;
}

sd_status sd_rig_get_keys(const sd_rig* rig, int32_t sweep, float* centers, float* orientations,
                          float* half_axes, int32_t* bones, int32_t* joint_parents,
                          float* fractions) {
    return guarded(__func__, [&] {
        const sd::Sweep& s = sweep_of(rig, sweep);
        for (int k = 0; k < s.key_count(); ++k) {
            const sd::KeyEllipse& e = s.keys[k];
            for (int i = 0; i < 3 && centers; ++i) centers[3 * k + i] = static_cast<float>(e.center[i]);
            if (orientations) {
                const double q[4] = {e.orientation.w, e.orientation.x, e.orientation.y, e.orientation.z};
                for (int i = 0; i < 4; ++i) orientations[4 * k + i] = static_cast<float>(q[i]);
            }
            if (half_axes) {
                half_axes[2 * k] = static_cast<float>(e.a);
                half_axes[2 * k + 1] = static_cast<float>(e.b);
            }
            if (bones) bones[k] = e.bone;
            if (joint_parents) joint_parents[k] = e.joint_parent;
            if (fractions) {
                fractions[2 * k] = static_cast<float>(e.swing_fraction);
                fractions[2 * k + 1] = static_cast<float>(e.twist_fraction);
            }
        }
        return SD_OK;
    });
}

sd_status sd_rig_sweep_rest_volume(const sd_rig* rig, int32_t sweep, double* out_volume) {
    return guarded(__func__, [&] {
        const sd::Sweep& s = sweep_of(rig, sweep);
        SD_REQUIRE(out_volume, "out_volume is NULL");
        *out_volume = s.rest_volume;
        return SD_OK;
    });
}

sd_status sd_rig_evaluate_sweep(const sd_rig* rig, int32_t sweep, int32_t count, const float* u,
                                float* centers, float* tangents, float* normals, float* rotations,
                                float* half_axes) {
    return guarded(__func__, [&] {
        const sd::Sweep& s = sweep_of(rig, sweep);
        SD_REQUIRE(count >= 0 && count <= 100'000'000, "count is out of range");
        SD_REQUIRE(u || count == 0, "u is NULL");
        for (int i = 0; i < count; ++i)
            SD_REQUIRE(std::isfinite(u[i]) && u[i] >= 0.0f && u[i] <= 1.0f,
                       "u[" + std::to_string(i) + "] is not in [0, 1]");
        const sd::SweepGeometry& g = s.rest_geometry;
        for (int i = 0; i < count; ++i) {
            int span;
            double uu;
            sd::split_parameter(g.span_count(), u[i], &span, &uu);
            const sd::dvec3 c = g.center(span, uu), t = g.tangent(span, uu);
            const sd::dmat3 r = g.rotation(span, uu);
            const sd::dvec2 ab = s.rest_half_axes.at(span, uu);
            for (int j = 0; j < 3; ++j) {
                if (centers) centers[3 * i + j] = static_cast<float>(c[j]);
                if (tangents) tangents[3 * i + j] = static_cast<float>(t[j]);
                if (normals) normals[3 * i + j] = static_cast<float>(r[2][j]);
            }
            for (int j = 0; rotations && j < 9; ++j) rotations[9 * i + j] = static_cast<float>(r[j / 3][j % 3]);
            if (half_axes) {
                half_axes[2 * i] = static_cast<float>(ab.x);
                half_axes[2 * i + 1] = static_cast<float>(ab.y);
            }
        }
        return SD_OK;
    });
}

sd_status sd_rig_serialize(const sd_rig* rig, uint8_t* buffer, int64_t capacity, int64_t* out_size) {
    return guarded(__func__, [&] {
        SD_REQUIRE(rig, "rig is NULL");
        return write_blob(sd::serialize_rig(rig->rig), buffer, capacity, out_size);
    });
}

sd_status sd_rig_deserialize(const uint8_t* buffer, int64_t size, sd_rig** out_rig) {
    return guarded(__func__, [&] {
        SD_REQUIRE(out_rig, "out_rig is NULL");
        if (size < 0) throw sd::CorruptData("negative blob size");
        auto rig = std::make_unique<sd_rig>();
        rig->rig = sd::deserialize_rig(buffer, static_cast<size_t>(size));
        *out_rig = rig.release();
        return SD_OK;
    }, SD_ERR_CORRUPT_DATA);
}

sd_status sd_bind(const sd_rig* rig, int32_t vertex_count, const float* positions,
                  int32_t sweep_slots, const int32_t* sweep_ids, const float* sweep_weights,
                  int32_t bone_slots, const int32_t* bone_ids, const float* bone_weights,
                  sd_binding** out_binding) {
    return guarded(__func__, [&] {
        SD_REQUIRE(rig && out_binding, "rig or out_binding is NULL");
        auto b = std::make_unique<sd_binding>();
        b->binding = sd::bind_vertices(rig->rig, vertex_count, positions, sweep_slots, sweep_ids,
                                       sweep_weights, bone_slots, bone_ids, bone_weights);
        *out_binding = b.release();
        return SD_OK;
    });
}

void sd_binding_destroy(sd_binding* binding) { delete binding; }

int32_t sd_binding_vertex_count(const sd_binding* binding) {
    return binding ? binding->binding.vertex_count() : -1;
}

sd_status sd_binding_get_parameters(const sd_binding* binding, int32_t vertex_count,
                                    int32_t* sweep, float* t, float* theta) {
    return guarded(__func__, [&] {
        SD_REQUIRE(binding, "binding is NULL");
        const sd::Binding& b = binding->binding;
        if (vertex_count != b.vertex_count())
            return fail(SD_ERR_MISMATCH, "vertex_count " + std::to_string(vertex_count) +
                                             " differs from the binding's " +
                                             std::to_string(b.vertex_count()));
        for (int v = 0; v < b.vertex_count(); ++v) {
            const sd::SweepInfluence* best = nullptr;
            for (uint32_t i = b.sweep_offsets[v]; i < b.sweep_offsets[v + 1]; ++i)
                if (!best || b.sweep_influences[i].weight > best->weight) best = &b.sweep_influences[i];
            if (sweep) sweep[v] = best ? best->sweep : -1;
            // t as a global parameter in [0, 1], uniform per span, like sd_rig_evaluate_sweep.
            if (t) t[v] = best ? static_cast<float>(best->span) + best->u : 0.0f;
            if (theta) theta[v] = best ? std::atan2(best->sin_theta, best->cos_theta) : 0.0f;
        }
        return SD_OK;
    });
}

sd_status sd_binding_serialize(const sd_binding* binding, uint8_t* buffer, int64_t capacity,
                               int64_t* out_size) {
    return guarded(__func__, [&] {
        SD_REQUIRE(binding, "binding is NULL");
        return write_blob(sd::serialize_binding(binding->binding), buffer, capacity, out_size);
    });
}

sd_status sd_binding_deserialize(const uint8_t* buffer, int64_t size, sd_binding** out_binding) {
    return guarded(__func__, [&] {
        SD_REQUIRE(out_binding, "out_binding is NULL");
        if (size < 0) throw sd::CorruptData("negative blob size");
        auto b = std::make_unique<sd_binding>();
        b->binding = sd::deserialize_binding(buffer, static_cast<size_t>(size));
        *out_binding = b.release();
        return SD_OK;
    }, SD_ERR_CORRUPT_DATA);
}

sd_status sd_deformer_create(const sd_rig* rig, const sd_binding* binding, sd_deformer** out) {
    return guarded(__func__, [&] {
        SD_REQUIRE(rig && binding && out, "rig, binding or out_deformer is NULL");
        if (binding->binding.rig_fingerprint != sd::rig_fingerprint(rig->rig))
            return fail(SD_ERR_MISMATCH, "the binding was made for another rig; re-bind");
        auto d = std::make_unique<sd_deformer>();
        d->deformer = std::make_unique<sd::Deformer>(rig->rig, binding->binding);
        *out = d.release();
        return SD_OK;
    });
}

void sd_deformer_destroy(sd_deformer* deformer) { delete deformer; }

sd_status sd_deformer_set_volume_preservation(sd_deformer* d, int32_t enabled, float strength) {
    return guarded(__func__, [&] {
        SD_REQUIRE(d, "deformer is NULL");
        d->deformer->set_volume_preservation(enabled != 0, strength);
        return SD_OK;
    });
}

sd_status sd_deformer_set_volume_offsets(sd_deformer* d, int32_t sweep_count, const float* offsets) {
    return guarded(__func__, [&] {
        SD_REQUIRE(d && offsets, "deformer or offsets is NULL");
        if (sweep_count != static_cast<int32_t>(d->deformer->rig().sweeps.size()))
            return fail(SD_ERR_MISMATCH, "sweep_count differs from the rig's");
        d->deformer->set_volume_offsets(std::vector<double>(offsets, offsets + sweep_count));
        return SD_OK;
    });
}

sd_status sd_deform(sd_deformer* d, int32_t bone_count, const float* pose, int32_t vertex_count,
                    float* out_positions) {
    return guarded(__func__, [&] {
        SD_REQUIRE(d && pose && out_positions, "deformer, pose or out_positions is NULL");
        if (bone_count != d->deformer->rig().skeleton.bone_count())
            return fail(SD_ERR_MISMATCH, "pose has " + std::to_string(bone_count) +
                                             " bones, the rig " +
                                             std::to_string(d->deformer->rig().skeleton.bone_count()));
        if (vertex_count != d->deformer->vertex_count())
            return fail(SD_ERR_MISMATCH, "vertex_count " + std::to_string(vertex_count) +
                                             " differs from the binding's " +
                                             std::to_string(d->deformer->vertex_count()));
        d->deformer->deform(pose, out_positions);
        return SD_OK;
    });
}

sd_status sd_deform_frames(sd_deformer* d, int32_t bone_count, const float* pose, int32_t vertex_count,
                           float* out_positions, float* out_frames) {
    return guarded(__func__, [&] {
        SD_REQUIRE(d && pose && out_positions && out_frames, "deformer, pose, out_positions or out_frames is NULL");
        if (bone_count != d->deformer->rig().skeleton.bone_count())
            return fail(SD_ERR_MISMATCH, "pose has " + std::to_string(bone_count) + " bones, the rig " +
                                             std::to_string(d->deformer->rig().skeleton.bone_count()));
        if (vertex_count != d->deformer->vertex_count())
            return fail(SD_ERR_MISMATCH, "vertex_count " + std::to_string(vertex_count) +
                                             " differs from the binding's " +
                                             std::to_string(d->deformer->vertex_count()));
        d->deformer->deform_frames(pose, out_positions, out_frames);
        return SD_OK;
    });
}

sd_status sd_deformer_get_volumes(const sd_deformer* d, int32_t sweep_count, double* rest,
                                  double* before, double* after) {
    return guarded(__func__, [&] {
        SD_REQUIRE(d, "deformer is NULL");
        const sd::Deformer& def = *d->deformer;
        if (sweep_count != static_cast<int32_t>(def.rig().sweeps.size()))
            return fail(SD_ERR_MISMATCH, "sweep_count differs from the rig's");
        for (int s = 0; s < sweep_count; ++s) {
            if (rest) rest[s] = def.rig().sweeps[s].corrected_rest_volume;
            if (before) before[s] = def.volume_before[s];
            if (after) after[s] = def.volume_after[s];
        }
        return SD_OK;
    });
}

sd_status sd_deformer_get_volume_iterations(const sd_deformer* d, int32_t sweep_count,
                                            int32_t* iterations) {
    return guarded(__func__, [&] {
        SD_REQUIRE(d && iterations, "deformer or iterations is NULL");
        if (sweep_count != static_cast<int32_t>(d->deformer->rig().sweeps.size()))
            return fail(SD_ERR_MISMATCH, "sweep_count differs from the rig's");
        for (int s = 0; s < sweep_count; ++s) iterations[s] = d->deformer->volume_iterations[s];
        return SD_OK;
    });
}

// ---- key-ellipse editing (Sect. 4.2) ----

sd_status sd_rig_key_joint(const sd_rig* rig, int32_t sweep, int32_t key, int32_t* parent_bone,
                           int32_t* child_bone, float* rest_angle) {
    return guarded(__func__, [&] {
        key_of(rig, sweep, key);
        const sd::KeyJoint& j = rig->rig.sweeps[sweep].joints[key];
        if (parent_bone) *parent_bone = j.parent;
        if (child_bone) *child_bone = j.child;
        if (rest_angle) *rest_angle = static_cast<float>(j.rest_angle);
        return SD_OK;
    });
}

sd_status sd_rig_key_joint_angle(const sd_rig* rig, int32_t sweep, int32_t key, int32_t bone_count,
                                 const float* pose, float* out_angle) {
    return guarded(__func__, [&] {
        key_of(rig, sweep, key);
        SD_REQUIRE(out_angle, "out_angle is NULL");
        const sd::SkeletonPose p = pose_of(rig->rig, bone_count, pose);
        *out_angle = static_cast<float>(sd::joint_angle(rig->rig.sweeps[sweep].joints[key], p));
        return SD_OK;
    });
}

sd_status sd_rig_set_key_correction(sd_rig* rig, int32_t sweep, int32_t key, float angle,
                                    const float* values, int32_t muted, int32_t* out_index) {
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

sd_status sd_rig_mute_key_correction(sd_rig* rig, int32_t sweep, int32_t key, int32_t index,
                                     int32_t muted) {
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

sd_status sd_rig_get_key_corrections(const sd_rig* rig, int32_t sweep, int32_t key, int32_t count,
                                     float* angles, float* values, int32_t* muted) {
    return guarded(__func__, [&] {
        const sd::KeyEllipse& e = key_of(rig, sweep, key);
        if (count != static_cast<int32_t>(e.corrections.size()))
            return fail(SD_ERR_MISMATCH, "count " + std::to_string(count) + " differs from the key's " +
                                             std::to_string(e.corrections.size()) + " corrections");
        for (int i = 0; i < count; ++i) write_correction(e.corrections[i], i, angles, values, muted);
        return SD_OK;
    });
}

sd_status sd_rig_key_correction_at(const sd_rig* rig, int32_t sweep, int32_t key, float angle,
                                   float* values) {
    return guarded(__func__, [&] {
        const sd::KeyEllipse& e = key_of(rig, sweep, key);
        SD_REQUIRE(values, "values is NULL");
        SD_REQUIRE(std::isfinite(angle), "angle is not finite");
        write_values(sd::correction_at(e.corrections, rig->rig.sweeps[sweep].joints[key].rest_angle, angle),
                     values);
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

sd_status sd_rig_get_corrections(const sd_rig* rig, int32_t count, int32_t* sweeps, int32_t* keys,
                                 float* angles, float* values, int32_t* muted) {
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

sd_status sd_rig_pose_keys(const sd_rig* rig, int32_t sweep, int32_t bone_count, const float* pose,
                           int32_t corrected, int32_t key_count, float* centers, float* orientations,
                           float* half_axes, float* angles) {
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

sd_status sd_rig_evaluate_posed_sweep(const sd_rig* rig, int32_t sweep, int32_t bone_count,
                                      const float* pose, int32_t count, const float* u, float* centers,
                                      float* rotations, float* half_axes) {
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
        const sd::SweepGeometry g(c, q);
        for (int i = 0; i < count; ++i) {
            int span;
            double uu;
            sd::split_parameter(g.span_count(), u[i], &span, &uu);
            const sd::dvec3 ci = g.center(span, uu);
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

sd_status sd_deformer_set_rig_corrections(sd_deformer* d, int32_t count, const int32_t* sweeps,
                                          const int32_t* keys, const float* angles, const float* values,
                                          const int32_t* muted) {
    return guarded(__func__, [&] {
        SD_REQUIRE(d, "deformer is NULL");
        d->deformer->set_corrections(records_from(count, sweeps, keys, angles, values, muted));
        return SD_OK;
    });
}

}  // extern "C"
