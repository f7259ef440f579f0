// The C ABI of the automatic fitting (sweepdeform.h, "automatic fitting"). No exception
// leaves this file.
#include "sweepdeform/sweepdeform.h"

#include "abi/guard.h"
#include "fit/fit_rig.h"

#include <memory>
#include <string>

struct sd_fit_result {
    sd::fit::FitResult result;
};

namespace {

using sd::abi::fail;
using sd::abi::guarded;

}  // namespace

extern "C" {

sd_status sd_fit_rig(int32_t vertex_count, const float* positions, int32_t triangle_count, const int32_t* triangles,
                     int32_t bone_count, const int32_t* parents, const float* rest, const float* heads,
                     const float* tails, const char* const* bone_names, int32_t skin_slots, const int32_t* skin_bones,
                     const float* skin_weights, int32_t keys_per_link, int32_t chain_count,
                     const int32_t* chain_offsets, const int32_t* chain_bones, sd_fit_result** out_result) {
    return guarded(__func__, [&] {
        SD_REQUIRE(out_result, "out_result is NULL");
        SD_REQUIRE(skin_slots >= 0 && skin_slots <= 64, "skin_slots must be in 0..64");
        SD_REQUIRE(keys_per_link >= 0 && keys_per_link <= 16, "keys_per_link must be in 0..16");
        sd::fit::FitInput in;
        in.skeleton = sd::Skeleton::from_arrays(bone_count, parents, rest, heads, tails);
        in.vertex_count = vertex_count;
        in.positions = positions;
        in.triangle_count = triangle_count;
        in.triangles = triangles;
        in.bone_names = sd::fit::names_from_c(in.skeleton.bone_count(), bone_names);
        in.skin_slots = skin_slots;
        in.skin_bones = skin_bones;
        in.skin_weights = skin_weights;
        in.chains = sd::fit::chains_from_offsets(chain_count, chain_offsets, chain_bones);
        sd::fit::FitOptions options;
        options.keys.keys_per_link = keys_per_link;
        auto r = std::make_unique<sd_fit_result>();
        r->result = sd::fit::fit_rig(in, options);
        *out_result = r.release();
        return SD_OK;
    });
}

void sd_fit_result_destroy(sd_fit_result* result) { delete result; }

sd_status sd_fit_result_rig(const sd_fit_result* result, sd_rig** out_rig) {
    return guarded(__func__, [&] {
        SD_REQUIRE(result && out_rig, "result or out_rig is NULL");
        auto rig = std::make_unique<sd_rig>();
        rig->rig = result->result.rig;
        *out_rig = rig.release();
        return SD_OK;
    });
}

sd_status sd_fit_result_slot_counts(const sd_fit_result* result, int32_t* sweep_slots, int32_t* bone_slots) {
    return guarded(__func__, [&] {
        SD_REQUIRE(result, "result is NULL");
        if (sweep_slots) *sweep_slots = result->result.weights.sweep_slots;
        if (bone_slots) *bone_slots = result->result.weights.bone_slots;
        return SD_OK;
    });
}

sd_status sd_fit_result_weights(const sd_fit_result* result, int32_t vertex_count, int32_t sweep_slots,
                                int32_t* sweep_ids, float* sweep_weights, int32_t bone_slots, int32_t* bone_ids,
                                float* bone_weights) {
    return guarded(__func__, [&] {
        SD_REQUIRE(result, "result is NULL");
        const sd::fit::RegionWeights& w = result->result.weights;
        const int V = result->result.mesh.vertices;
        if (vertex_count != V)
            return fail(SD_ERR_MISMATCH, std::string(__func__) + ": vertex_count " + std::to_string(vertex_count) +
                                             " differs from the fitted mesh's " + std::to_string(V));
        SD_REQUIRE(sweep_slots >= w.sweep_slots && sweep_slots <= 64,
                   "sweep_slots must be in " + std::to_string(w.sweep_slots) + "..64");
        SD_REQUIRE(bone_slots >= w.bone_slots && bone_slots <= 64,
                   "bone_slots must be in " + std::to_string(w.bone_slots) + "..64");
        SD_REQUIRE(sweep_ids && sweep_weights && bone_ids && bone_weights, "a weight array is NULL");
        for (int v = 0; v < V; ++v) {
            for (int i = 0; i < sweep_slots; ++i) {
                const bool has = i < w.sweep_slots;
                sweep_ids[static_cast<size_t>(v) * sweep_slots + i] =
                    has ? w.sweep_ids[static_cast<size_t>(v) * w.sweep_slots + i] : -1;
                sweep_weights[static_cast<size_t>(v) * sweep_slots + i] =
                    has ? w.sweep_weights[static_cast<size_t>(v) * w.sweep_slots + i] : 0.0f;
            }
            for (int i = 0; i < bone_slots; ++i) {
                const bool has = i < w.bone_slots;
                bone_ids[static_cast<size_t>(v) * bone_slots + i] =
                    has ? w.bone_ids[static_cast<size_t>(v) * w.bone_slots + i] : -1;
                bone_weights[static_cast<size_t>(v) * bone_slots + i] =
                    has ? w.bone_weights[static_cast<size_t>(v) * w.bone_slots + i] : 0.0f;
            }
        }
        return SD_OK;
    });
}

sd_status sd_fit_result_report(const sd_fit_result* result, char* buffer, int64_t capacity, int64_t* out_size) {
    return guarded(__func__, [&] {
        SD_REQUIRE(result, "result is NULL");
        const std::string& report = result->result.report;
        return sd::abi::write_bytes(report.c_str(), report.size() + 1, buffer, capacity, out_size, "the report");
    });
}

}  // extern "C"
