// The C ABI of bindings (sweepdeform.h, "binding"): binding a mesh to a rig, its parameters
// and binding blobs. No exception leaves this file.
#include "sweepdeform/sweepdeform.h"

#include "abi/guard.h"
#include "bind/bind.h"
#include "bind/serialize.h"

#include <cmath>
#include <memory>
#include <string>
#include <vector>

namespace {

using sd::abi::fail;
using sd::abi::guarded;
using sd::abi::write_blob;

}  // namespace

extern "C" {

sd_status sd_bind(const sd_rig* rig, int32_t vertex_count, const float* positions, int32_t sweep_slots,
                  const int32_t* sweep_ids, const float* sweep_weights, int32_t bone_slots, const int32_t* bone_ids,
                  const float* bone_weights, sd_binding** out_binding) {
    return guarded(__func__, [&] {
        SD_REQUIRE(rig && out_binding, "rig or out_binding is NULL");
        auto b = std::make_unique<sd_binding>();
        b->binding = sd::bind_vertices(rig->rig, vertex_count, positions, sweep_slots, sweep_ids, sweep_weights,
                                       bone_slots, bone_ids, bone_weights);
        *out_binding = b.release();
        return SD_OK;
    });
}

void sd_binding_destroy(sd_binding* binding) { delete binding; }

int32_t sd_binding_vertex_count(const sd_binding* binding) { return binding ? binding->binding.vertex_count() : -1; }

sd_status sd_binding_get_parameters(const sd_binding* binding, int32_t vertex_count, int32_t* sweep, float* t,
                                    float* theta) {
    return guarded(__func__, [&] {
        SD_REQUIRE(binding, "binding is NULL");
        const sd::Binding& b = binding->binding;
        if (vertex_count != b.vertex_count())
            return fail(SD_ERR_MISMATCH, "vertex_count " + std::to_string(vertex_count) +
                                             " differs from the binding's " + std::to_string(b.vertex_count()));
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

sd_status sd_binding_serialize(const sd_binding* binding, uint8_t* buffer, int64_t capacity, int64_t* out_size) {
    return guarded(__func__, [&] {
        SD_REQUIRE(binding, "binding is NULL");
        return write_blob(sd::serialize_binding(binding->binding), buffer, capacity, out_size);
    });
}

sd_status sd_binding_deserialize(const uint8_t* buffer, int64_t size, sd_binding** out_binding) {
    return guarded(
        __func__,
        [&] {
            SD_REQUIRE(out_binding, "out_binding is NULL");
            if (size < 0) throw sd::CorruptData("negative blob size");
            auto b = std::make_unique<sd_binding>();
            b->binding = sd::deserialize_binding(buffer, static_cast<size_t>(size));
            *out_binding = b.release();
            return SD_OK;
        },
        SD_ERR_CORRUPT_DATA);
}

}  // extern "C"
