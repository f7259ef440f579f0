// The C ABI of rigs (sweepdeform.h, "rig"): skeleton, sweeps of key ellipses, rest-pose
// queries and rig blobs. No exception leaves this file.
#include "sweepdeform/sweepdeform.h"

#include "abi/guard.h"
#include "bind/serialize.h"
#include "rig/rig.h"

#include <cmath>
#include <memory>
#include <string>
#include <vector>

namespace {

using sd::abi::fail;
using sd::abi::guarded;
using sd::abi::sweep_of;
using sd::abi::write_blob;

std::vector<sd::KeyEllipse> keys_from_arrays(int32_t K, const float* centers, const float* orientations,
                                             const float* half_axes, const int32_t* bones, const int32_t* joint_parents,
                                             const float* fractions) {
    SD_REQUIRE(K >= 2 && K <= 256, "key_count must be in 2..256");
    SD_REQUIRE(centers && orientations && half_axes && bones && joint_parents && fractions,
               "a key ellipse array is NULL");
    std::vector<sd::KeyEllipse> keys(K);
    for (int k = 0; k < K; ++k) {
        sd::KeyEllipse& e = keys[k];
        e.center = sd::dvec3(centers[3 * k], centers[3 * k + 1], centers[3 * k + 2]);
        e.orientation =
            sd::dquat(orientations[4 * k], orientations[4 * k + 1], orientations[4 * k + 2], orientations[4 * k + 3]);
        // Float input is unit only to ~1e-7: accept |q| within 1e-3 of 1, then normalise.
        const double qn = std::sqrt(glm::dot(e.orientation, e.orientation));
        if (!std::isfinite(qn) || std::abs(qn - 1.0) > 1e-3)
            throw sd::InvalidInput("key ellipse " + std::to_string(k) +
                                   ": orientation is not a unit quaternion (|q| = " + std::to_string(qn) + ")");
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

}  // namespace

extern "C" {

sd_status sd_rig_create(int32_t bone_count, const int32_t* parents, const float* rest, const float* heads,
                        const float* tails, sd_rig** out_rig) {
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

sd_status sd_rig_add_sweep(sd_rig* rig, int32_t key_count, const float* centers, const float* orientations,
                           const float* half_axes, const int32_t* bones, const int32_t* joint_parents,
                           const float* fractions, int32_t* out_sweep_index) {
    return guarded(__func__, [&] {
        SD_REQUIRE(rig, "rig is NULL");
        const int index = rig->rig.add_sweep(
            keys_from_arrays(key_count, centers, orientations, half_axes, bones, joint_parents, fractions));
        if (out_sweep_index) *out_sweep_index = index;
        return SD_OK;
    });
}

int32_t sd_rig_bone_count(const sd_rig* rig) { return rig ? rig->rig.skeleton.bone_count() : -1; }
int32_t sd_rig_sweep_count(const sd_rig* rig) { return rig ? static_cast<int32_t>(rig->rig.sweeps.size()) : -1; }

int32_t sd_rig_key_count(const sd_rig* rig, int32_t sweep) {
    int32_t count = -1;
    guarded(__func__, [&] {
        count = sweep_of(rig, sweep).key_count();
        return SD_OK;
    });
    return count;
}

sd_status sd_rig_get_keys(const sd_rig* rig, int32_t sweep, float* centers, float* orientations, float* half_axes,
                          int32_t* bones, int32_t* joint_parents, float* fractions) {
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

sd_status sd_rig_evaluate_sweep(const sd_rig* rig, int32_t sweep, int32_t count, const float* u, float* centers,
                                float* tangents, float* normals, float* rotations, float* half_axes) {
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
    return guarded(
        __func__,
        [&] {
            SD_REQUIRE(out_rig, "out_rig is NULL");
            if (size < 0) throw sd::CorruptData("negative blob size");
            auto rig = std::make_unique<sd_rig>();
            rig->rig = sd::deserialize_rig(buffer, static_cast<size_t>(size));
            *out_rig = rig.release();
            return SD_OK;
        },
        SD_ERR_CORRUPT_DATA);
}

}  // extern "C"
