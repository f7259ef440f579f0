// C ABI: relative shape keys mixed into displacements (deform/shape_key_mix.h).
#include "sweepdeform/sweepdeform.h"

#include "abi/guard.h"
#include "deform/shape_key_mix.h"

#include <cmath>
#include <string>
#include <vector>

namespace {
using sd::abi::guarded;
}  // namespace

extern "C" {

sd_status sd_mix_shape_keys(int32_t vertex_count, const float* rest, int32_t block_count, const float* blocks,
                            int32_t term_count, const int32_t* term_blocks, const float* term_values,
                            int32_t* out_moved_count, int32_t* out_moved, float* out_moves) {
    return guarded(__func__, [&] {
        SD_REQUIRE(rest && blocks && out_moved_count && out_moved && out_moves,
                   "rest, blocks, out_moved_count, out_moved or out_moves is NULL");
        SD_REQUIRE(vertex_count >= 0, "vertex_count is negative");
        SD_REQUIRE(block_count >= 1, "block_count must be at least 1 (the reference key)");
        SD_REQUIRE(term_count >= 0, "term_count is negative");
        SD_REQUIRE(term_count == 0 || (term_blocks && term_values), "term_blocks or term_values is NULL");
        std::vector<sd::ShapeKeyTerm> terms(static_cast<size_t>(term_count));
        for (int32_t t = 0; t < term_count; ++t) {
            const int32_t key = term_blocks[2 * t], relative = term_blocks[2 * t + 1];
            SD_REQUIRE(key >= 0 && key < block_count && relative >= 0 && relative < block_count,
                       "term " + std::to_string(t) + " names a block outside [0, block_count)");
            SD_REQUIRE(std::isfinite(term_values[t]) && std::abs(term_values[t]) <= 1e6f,
                       "term " + std::to_string(t) + " has a value that is not finite or beyond 1e6");
            terms[t] = {key, relative, term_values[t]};
        }
        const size_t n = 3 * static_cast<size_t>(vertex_count);
        // Finite and within ±1e12, so that every displacement is finite.
        sd::abi::require_within(rest, n, 1e12f, "rest");
        sd::abi::require_within(blocks, n * static_cast<size_t>(block_count), 1e12f, "blocks");
        *out_moved_count =
            sd::mix_shape_keys(vertex_count, rest, blocks, terms.data(), term_count, out_moved, out_moves);
        return SD_OK;
    });
}

}  // extern "C"
