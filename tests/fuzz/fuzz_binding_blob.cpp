// Loading a binding blob and using it with a rig: any blob that loads either is refused by
// sd_deformer_create or deforms to finite positions.
#include "fuzz_fixture.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    static const sdfuzz::Arm arm;
    sd_binding* b = nullptr;
    if (sd_binding_deserialize(data, static_cast<int64_t>(size), &b) != SD_OK) return 0;
    sd_deformer* d = nullptr;
    if (sd_deformer_create(arm.rig, b, &d) == SD_OK) {
        const int32_t V = sd_binding_vertex_count(b);
        std::vector<float> out(3 * static_cast<size_t>(V));
        if (sd_deform(d, 3, arm.rest, V, out.data()) == SD_OK) sdfuzz::require_finite(out.data(), out.size());
        sd_deformer_destroy(d);
    }
    sd_binding_destroy(b);
    return 0;
}
