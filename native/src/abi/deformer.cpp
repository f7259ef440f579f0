// The C ABI of deformers (sweepdeform.h, "deformation"): the per-frame call and the volume
// control's settings and figures. No exception leaves this file.
#include "sweepdeform/sweepdeform.h"

#include "abi/guard.h"
#include "deform/joint_volume_blob.h"
#include "bind/serialize.h"
#include "deform/deform.h"

#include <cmath>
#include <memory>
#include <string>
#include <vector>

namespace {

using sd::abi::check_frame_counts;
using sd::abi::fail;
using sd::abi::guarded;
using sd::abi::write_blob;

}  // namespace

extern "C" {

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

sd_status sd_deformer_hold_joint_volumes(sd_deformer* d, int32_t vertex_count, int32_t triangle_count,
                                         const int32_t* triangles, int32_t* out_joint_count) {
    return guarded(__func__, [&] {
        SD_REQUIRE(d && (triangles || triangle_count == 0), "deformer or triangles is NULL");
        if (vertex_count != d->deformer->vertex_count())
            return fail(SD_ERR_MISMATCH, "vertex_count differs from the binding's");
        std::vector<sd::JointVolumeTable> tables;
        if (triangle_count != 0) tables = sd::measure_joint_volumes(*d->deformer, triangle_count, triangles);
        d->deformer->set_joint_volumes(std::move(tables));
        if (out_joint_count) *out_joint_count = static_cast<int32_t>(d->deformer->joint_volumes().size());
        return SD_OK;
    });
}

sd_status sd_deformer_set_skin_triangles(sd_deformer* d, int32_t vertex_count, int32_t triangle_count,
                                         const int32_t* triangles) {
    return guarded(__func__, [&] {
        SD_REQUIRE(d && (triangles || triangle_count == 0), "deformer or triangles is NULL");
        SD_REQUIRE(triangle_count >= 0, "triangle_count is negative");
        if (vertex_count != d->deformer->vertex_count())
            return fail(SD_ERR_MISMATCH, "vertex_count differs from the binding's");
        d->deformer->set_skin_triangles(
            std::vector<int32_t>(triangles, triangles + 3 * static_cast<size_t>(triangle_count)));
        return SD_OK;
    });
}

sd_status sd_deformer_fill_trunk_as(sd_deformer* d, const sd_deformer* source) {
    return guarded(__func__, [&] {
        SD_REQUIRE(d && source, "deformer or source is NULL");
        if (sd::rig_fingerprint(d->deformer->rig()) != sd::rig_fingerprint(source->deformer->rig()))
            return fail(SD_ERR_MISMATCH, "the source deformer has another rig");
        d->deformer->fill_trunk_as(*source->deformer);
        return SD_OK;
    });
}

sd_status sd_deformer_hold_joint_volumes_of(sd_deformer* d, const sd_deformer* source, int32_t* out_joint_count) {
    return guarded(__func__, [&] {
        SD_REQUIRE(d && source, "deformer or source is NULL");
        if (sd::rig_fingerprint(d->deformer->rig()) != sd::rig_fingerprint(source->deformer->rig()))
            return fail(SD_ERR_MISMATCH, "the source deformer has another rig");
        std::vector<sd::JointVolumeTable> tables;
        {
            const auto lock = source->deformer->lock();
            tables = source->deformer->joint_volumes();
        }
        d->deformer->set_joint_volumes(std::move(tables));
        if (out_joint_count) *out_joint_count = static_cast<int32_t>(d->deformer->joint_volumes().size());
        return SD_OK;
    });
}

sd_status sd_deformer_serialize_joint_volumes(const sd_deformer* d, uint8_t* buffer, int64_t capacity,
                                              int64_t* out_size) {
    return guarded(__func__, [&] {
        SD_REQUIRE(d, "deformer is NULL");
        std::vector<sd::JointVolumeTable> tables;
        {
            const auto lock = d->deformer->lock();
            tables = d->deformer->joint_volumes();
        }
        return write_blob(sd::serialize_joint_volumes(tables, sd::rig_fingerprint(d->deformer->rig())), buffer,
                          capacity, out_size);
    });
}

sd_status sd_deformer_load_joint_volumes(sd_deformer* d, const uint8_t* blob, int64_t size, int32_t* out_joint_count) {
    return guarded(__func__, [&] {
        SD_REQUIRE(d, "deformer is NULL");
        if (size < 0) throw sd::CorruptData("negative blob size");
        uint64_t fingerprint = 0;
        std::vector<sd::JointVolumeTable> tables =
            sd::deserialize_joint_volumes(blob, static_cast<size_t>(size), &fingerprint);
        if (fingerprint != sd::rig_fingerprint(d->deformer->rig()))
            return fail(SD_ERR_MISMATCH, "the joint volumes were measured with another rig");
        d->deformer->set_joint_volumes(std::move(tables));
        if (out_joint_count) *out_joint_count = static_cast<int32_t>(d->deformer->joint_volumes().size());
        return SD_OK;
    });
}

sd_status sd_deform(sd_deformer* d, int32_t bone_count, const float* pose, int32_t vertex_count, float* out_positions) {
    return guarded(__func__, [&] {
        SD_REQUIRE(d && pose && out_positions, "deformer, pose or out_positions is NULL");
        if (const sd_status s = check_frame_counts(d, bone_count, vertex_count); s != SD_OK) return s;
        d->deformer->deform(pose, out_positions);
        return SD_OK;
    });
}

sd_status sd_deform_frames(sd_deformer* d, int32_t bone_count, const float* pose, int32_t vertex_count,
                           float* out_positions, float* out_frames) {
    return guarded(__func__, [&] {
        SD_REQUIRE(d && pose && out_positions && out_frames, "deformer, pose, out_positions or out_frames is NULL");
        if (const sd_status s = check_frame_counts(d, bone_count, vertex_count); s != SD_OK) return s;
        d->deformer->deform_frames(pose, out_positions, out_frames);
        return SD_OK;
    });
}

sd_status sd_deform_displaced(sd_deformer* d, int32_t bone_count, const float* pose, int32_t vertex_count,
                              int32_t moved_count, const int32_t* moved_vertices, const float* displacements,
                              float* out_positions, float* out_turned) {
    // sd_deform_frame without its check and sums (abi/deform_frame.cpp checks the arguments)
    return sd::abi::deform_frame(__func__, d, bone_count, pose, vertex_count, moved_count, moved_vertices,
                                 displacements, out_positions, out_turned, nullptr, 0.0f, nullptr, nullptr, nullptr,
                                 nullptr, nullptr, nullptr, 0, nullptr);
}

sd_status sd_deformer_get_volumes(const sd_deformer* d, int32_t sweep_count, double* rest, double* before,
                                  double* after) {
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

sd_status sd_deformer_get_volume_iterations(const sd_deformer* d, int32_t sweep_count, int32_t* iterations) {
    return guarded(__func__, [&] {
        SD_REQUIRE(d && iterations, "deformer or iterations is NULL");
        if (sweep_count != static_cast<int32_t>(d->deformer->rig().sweeps.size()))
            return fail(SD_ERR_MISMATCH, "sweep_count differs from the rig's");
        for (int s = 0; s < sweep_count; ++s) iterations[s] = d->deformer->volume_iterations[s];
        return SD_OK;
    });
}

}  // extern "C"
