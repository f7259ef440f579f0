// Binding arbitrary meshes (NaN/Inf, huge and tiny coordinates, duplicates, any weights) to a
// fixed rig, then deforming them at rest and in a bent pose.
#include "fuzz_fixture.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    static const sdfuzz::Arm arm;
    sdfuzz::Bytes in(data, size);
    const int32_t V = 1 + in.take<uint8_t>() % 64;
    const int32_t S = in.take<uint8_t>() % 3, K = in.take<uint8_t>() % 3;
    std::vector<float> pos(3 * V), sw(S * V), bw(K * V);
    std::vector<int32_t> sid(S * V), bid(K * V);
    for (auto& x : pos) x = in.take<float>();
    for (auto& i : sid) i = in.take<int8_t>() % 3;
    for (auto& w : sw) w = in.take<float>();
    for (auto& i : bid) i = in.take<int8_t>() % 5;
    for (auto& w : bw) w = in.take<float>();
    sd_binding* b = nullptr;
    if (sd_bind(arm.rig, V, pos.data(), S, sid.data(), sw.data(), K, bid.data(), bw.data(), &b) != SD_OK) return 0;
    sd_deformer* d = nullptr;
    if (sd_deformer_create(arm.rig, b, &d) != SD_OK) __builtin_trap();
    std::vector<float> out(3 * static_cast<size_t>(V));
    if (sd_deform(d, 3, arm.rest, V, out.data()) != SD_OK) __builtin_trap();
    sdfuzz::require_finite(out.data(), out.size());
    sd_deformer_destroy(d);
    sd_binding_destroy(b);
    return 0;
}
