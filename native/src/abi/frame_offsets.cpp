// C ABI: a frame's values for the caller's mesh in one pass (deform/frame_offsets.h).
#include "sweepdeform/sweepdeform.h"

#include "abi/guard.h"
#include "deform/frame_offsets.h"

#include <string>

namespace {
using sd::abi::guarded;
}  // namespace

extern "C" {

sd_status sd_compose_offsets(int32_t vertex_count, const float* positions, const float* rest, const float* base,
                             int32_t moved_count, const int32_t* moved_vertices, const float* turned,
                             const float* displacements, float* out) {
    return guarded(__func__, [&] {
        SD_REQUIRE(positions && rest && out, "positions, rest or out is NULL");
        SD_REQUIRE(vertex_count >= 0, "vertex_count is negative");
        SD_REQUIRE(moved_count >= 0 && moved_count <= vertex_count, "moved_count is not in [0, vertex_count]");
        SD_REQUIRE(moved_count == 0 || (moved_vertices && turned), "moved_vertices or turned is NULL");
        // Ascending and within the mesh: each moved vertex once (a repeat would add twice).
        for (int32_t i = 0; i < moved_count; ++i)
            SD_REQUIRE(moved_vertices[i] >= 0 && moved_vertices[i] < vertex_count &&
                           (i == 0 || moved_vertices[i] > moved_vertices[i - 1]),
                       "moved_vertices[" + std::to_string(i) + "] is not in [0, vertex_count) or not ascending");
        sd::compose_frame_offsets(vertex_count, positions, rest, base, moved_count, moved_vertices, turned,
                                  displacements, out);
        return SD_OK;
    });
}

}  // extern "C"
