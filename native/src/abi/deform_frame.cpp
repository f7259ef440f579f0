// C ABI: a frame for the caller's mesh in one parallel pass (sd_deform_frame): the deformation,
// and per block of vertices, while it is in its core's cache, the output check and the
// offsets' sums. Three calls and three passes over the mesh before it (0.52 + 0.06 + 0.05 ms
// per frame of the 75K-vertex fixture in Blender 5.2); no exception leaves this file.
#include "sweepdeform/sweepdeform.h"

#include "abi/guard.h"
#include "deform/frame_offsets.h"
#include "deform/output_check.h"
#include "math/flush_denormals.h"

#include <functional>
#include <optional>
#include <string>

namespace sd::abi {

sd_status deform_frame(const char* function, sd_deformer* d, int32_t bone_count, const float* pose,
                       int32_t vertex_count, int32_t moved_count, const int32_t* moved_vertices,
                       const float* displacements, float* out_positions, float* out_turned,
                       const sd_output_check* check, float ratio_limit, int32_t* out_beyond, float* out_worst_ratio,
                       int32_t* out_worst_vertex, int32_t* out_worst_bone, const float* rest, const float* base,
                       int32_t subtract_displacements, float* out_composed) {
    return guarded(function, [&] {
        SD_REQUIRE(d && pose && out_positions, "deformer, pose or out_positions is NULL");
        SD_REQUIRE(moved_count >= 0, "moved_count is negative");
        SD_REQUIRE(moved_count == 0 || (moved_vertices && displacements && out_turned),
                   "moved_vertices, displacements or out_turned is NULL");
        if (const sd_status s = check_frame_counts(d, bone_count, vertex_count); s != SD_OK) return s;
        SD_REQUIRE(moved_count <= vertex_count, "moved_count exceeds vertex_count");
        for (int32_t i = 0; i < moved_count; ++i)
            SD_REQUIRE(moved_vertices[i] >= 0 && moved_vertices[i] < vertex_count &&
                           (i == 0 || moved_vertices[i] > moved_vertices[i - 1]),
                       "moved_vertices must be ascending vertex indices (index " + std::to_string(i) + ")");
        // (bounded so that J d stays finite for any pose sd_deform accepts)
        sd::abi::require_within(displacements, 3 * static_cast<size_t>(moved_count), 1e12f, "displacements");
        if (out_composed) {
            SD_REQUIRE(rest, "rest is NULL");
            SD_REQUIRE(out_composed != out_positions, "out_composed is out_positions");
        }
        if (check) {
            if (check->check->vertex_count() != vertex_count || check->check->bone_count() != bone_count)
                return fail(SD_ERR_MISMATCH, "the check was made for another mesh or rig");
        }
        // The check's frame validates the limit and the pose before anything is written.
        std::optional<sd::OutputCheck::Frame> frame;
        if (check) frame.emplace(*check->check, pose, ratio_limit, nullptr, sd::SweepKernel::kVertexBlock);
        const float* subtracted = subtract_displacements ? displacements : nullptr;
        const std::function<void(int32_t)> after_block = [&](int32_t block) {
            if (frame) {  // with denormals flushed, as sd_output_check_run's tasks
                const sd::FlushDenormals flush;
                frame->range(out_positions, block);
            }
            if (!out_composed) return;
            const int32_t begin = block * sd::SweepKernel::kVertexBlock;
            const int32_t end = std::min(vertex_count, begin + sd::SweepKernel::kVertexBlock);
            sd::compose_frame_offsets_range(begin, end, out_positions, rest, base, moved_count, moved_vertices,
                                            out_turned, subtracted, out_composed);
        };
        if (frame || out_composed)
            d->deformer->deform_in_blocks(pose, moved_count, moved_vertices, displacements, out_positions, out_turned,
                                          after_block);
        else
            d->deformer->deform_displaced(pose, moved_count, moved_vertices, displacements, out_positions, out_turned);
        const sd::OutputCheck::Verdict v = frame ? frame->verdict() : sd::OutputCheck::Verdict{};
        if (out_beyond) *out_beyond = v.beyond;
        if (out_worst_ratio) *out_worst_ratio = static_cast<float>(v.worst_ratio);
        if (out_worst_vertex) *out_worst_vertex = v.worst_vertex;
        if (out_worst_bone) *out_worst_bone = v.worst_bone;
        return SD_OK;
    });
}

}  // namespace sd::abi

extern "C" {

sd_status sd_deform_frame(sd_deformer* d, int32_t bone_count, const float* pose, int32_t vertex_count,
                          int32_t moved_count, const int32_t* moved_vertices, const float* displacements,
                          float* out_positions, float* out_turned, const sd_output_check* check, float ratio_limit,
                          int32_t* out_beyond, float* out_worst_ratio, int32_t* out_worst_vertex,
                          int32_t* out_worst_bone, const float* rest, const float* base, int32_t subtract_displacements,
                          float* out_composed) {
    return sd::abi::deform_frame(__func__, d, bone_count, pose, vertex_count, moved_count, moved_vertices,
                                 displacements, out_positions, out_turned, check, ratio_limit, out_beyond,
                                 out_worst_ratio, out_worst_vertex, out_worst_bone, rest, base, subtract_displacements,
                                 out_composed);
}

}  // extern "C"
