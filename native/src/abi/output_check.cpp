// The C ABI of the output check (sweepdeform.h, "the output check", issue 15): a bound on each
// frame's output and its linear-blend fallback. No exception leaves this file.
#include "sweepdeform/sweepdeform.h"

#include "abi/guard.h"
#include "deform/output_check.h"

#include <memory>
#include <string>

namespace {

using sd::abi::fail;
using sd::abi::guarded;

/// The counts a frame's call gives, against the check's.
sd_status check_counts(const sd_output_check* c, int32_t bone_count, int32_t vertex_count) {
    if (bone_count != c->check->bone_count())
        return fail(SD_ERR_MISMATCH, "pose has " + std::to_string(bone_count) + " bones, the check " +
                                         std::to_string(c->check->bone_count()));
    if (vertex_count != c->check->vertex_count())
        return fail(SD_ERR_MISMATCH, "vertex_count " + std::to_string(vertex_count) + " differs from the check's " +
                                         std::to_string(c->check->vertex_count()));
    return SD_OK;
}

}  // namespace

extern "C" {

sd_status sd_output_check_create(int32_t vertex_count, const float* rest_positions, int32_t bone_count,
                                 const float* rest_pose, const float* bone_lengths, int32_t skin_slots,
                                 const int32_t* skin_bones, const float* skin_weights, float floor_share,
                                 sd_output_check** out_check) {
    return guarded(__func__, [&] {
        SD_REQUIRE(out_check, "out_check is NULL");
        auto c = std::make_unique<sd_output_check>();
        c->check = std::make_unique<sd::OutputCheck>(vertex_count, rest_positions, bone_count, rest_pose, bone_lengths,
                                                     skin_slots, skin_bones, skin_weights, floor_share);
        *out_check = c.release();
        return SD_OK;
    });
}

void sd_output_check_destroy(sd_output_check* check) { delete check; }

sd_status sd_output_check_run(const sd_output_check* check, int32_t bone_count, const float* pose, int32_t vertex_count,
                              const float* positions, float ratio_limit, int32_t* out_beyond, float* out_worst_ratio,
                              int32_t* out_worst_vertex, int32_t* out_worst_bone, float* out_ratios) {
    return guarded(__func__, [&] {
        SD_REQUIRE(check && pose && positions, "check, pose or positions is NULL");
        if (const sd_status s = check_counts(check, bone_count, vertex_count); s != SD_OK) return s;
        // Validated before anything is written: out_ratios is filled only by a check that succeeds.
        const sd::OutputCheck::Verdict v = check->check->check(pose, positions, ratio_limit, out_ratios);
        if (out_beyond) *out_beyond = v.beyond;
        if (out_worst_ratio) *out_worst_ratio = static_cast<float>(v.worst_ratio);
        if (out_worst_vertex) *out_worst_vertex = v.worst_vertex;
        if (out_worst_bone) *out_worst_bone = v.worst_bone;
        return SD_OK;
    });
}

sd_status sd_output_check_linear_blend(const sd_output_check* check, int32_t bone_count, const float* pose,
                                       int32_t vertex_count, float* out_positions) {
    return guarded(__func__, [&] {
        SD_REQUIRE(check && pose && out_positions, "check, pose or out_positions is NULL");
        if (const sd_status s = check_counts(check, bone_count, vertex_count); s != SD_OK) return s;
        check->check->linear_blend(pose, out_positions);
        return SD_OK;
    });
}

}  // extern "C"
