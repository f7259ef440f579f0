// Automatic fitting of arbitrary meshes (random topology, NaN/Inf, duplicates, huge and tiny
// coordinates) to the fixed arm skeleton: an error, or a rig whose weights bind.
#include "fuzz_fixture.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    static const sdfuzz::Arm arm;
    sdfuzz::Bytes in(data, size);
    const int32_t V = 3 + in.take<uint8_t>() % 120;
    const int32_t T = 1 + in.take<uint8_t>() % 200;
    const float scale = in.take<uint8_t>() < 200 ? 0.05f : in.take<float>();
    std::vector<float> pos(3 * V);
    for (int v = 0; v < V; ++v) {  // mostly a noisy tube around the arm, sometimes raw floats
        const uint8_t mode = in.take<uint8_t>();
        if (mode < 220) {
            pos[3 * v] = 2.3f * (v % 23) / 22.0f;
            pos[3 * v + 1] = scale * std::cos(0.7f * static_cast<float>(v)) + in.take<int8_t>() / 2048.0f;
            pos[3 * v + 2] = scale * std::sin(0.7f * static_cast<float>(v)) + in.take<int8_t>() / 2048.0f;
        } else {
            for (int i = 0; i < 3; ++i) pos[3 * v + i] = in.take<float>();
        }
    }
    std::vector<int32_t> tris(3 * T);
    for (auto& t : tris) t = in.take<int16_t>() % (V + 2);
    const int32_t keys = in.take<uint8_t>() % 5;
    sd_fit_result* fit = nullptr;
    if (sd_fit_rig(V, pos.data(), T, tris.data(), 3, arm.parents, arm.rest, arm.heads, arm.tails, nullptr, 0, nullptr,
                   nullptr, keys, 0, nullptr, nullptr, &fit) != SD_OK)
        return 0;
    int32_t S = 0, K = 0;
    if (sd_fit_result_slot_counts(fit, &S, &K) != SD_OK) __builtin_trap();
    std::vector<int32_t> sid(S * V), bid(K * V);
    std::vector<float> sw(S * V), bw(K * V);
    if (sd_fit_result_weights(fit, V, S, sid.data(), sw.data(), K, bid.data(), bw.data()) != SD_OK) __builtin_trap();
    sd_rig* rig = nullptr;
    if (sd_fit_result_rig(fit, &rig) != SD_OK) __builtin_trap();
    sd_binding* b = nullptr;
    if (sd_bind(rig, V, pos.data(), S, sid.data(), sw.data(), K, bid.data(), bw.data(), &b) == SD_OK) {
        sd_deformer* d = nullptr;
        if (sd_deformer_create(rig, b, &d) != SD_OK) __builtin_trap();
        std::vector<float> out(3 * static_cast<size_t>(V));
        if (sd_deform(d, 3, arm.rest, V, out.data()) != SD_OK) __builtin_trap();
        sdfuzz::require_finite(out.data(), out.size());
        sd_deformer_destroy(d);
        sd_binding_destroy(b);
    }
    sd_rig_destroy(rig);
    sd_fit_result_destroy(fit);
    return 0;
}
