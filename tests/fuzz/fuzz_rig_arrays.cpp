// Building a rig from arbitrary arrays: skeleton and one sweep, every number from the fuzzer.
#include "fuzz_fixture.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    sdfuzz::Bytes in(data, size);
    const int32_t B = 1 + in.take<uint8_t>() % 6;
    std::vector<int32_t> parents(B);
    std::vector<float> rest(16 * B), heads(3 * B), tails(3 * B);
    for (auto& p : parents) p = in.take<int8_t>() % 8;
    for (auto& x : rest) x = in.take<float>();
    for (auto& x : heads) x = in.take<float>();
    for (auto& x : tails) x = in.take<float>();
    sd_rig* rig = nullptr;
    if (sd_rig_create(B, parents.data(), rest.data(), heads.data(), tails.data(), &rig) != SD_OK) return 0;
    const int32_t K = in.take<uint8_t>() % 12;
    std::vector<float> centers(3 * K), orientations(4 * K), half_axes(2 * K), fractions(2 * K);
    std::vector<int32_t> bones(K), joint_parents(K);
    for (int k = 0; k < K; ++k) {
        for (int i = 0; i < 3; ++i) centers[3 * k + i] = in.take<float>();
        for (int i = 0; i < 4; ++i) orientations[4 * k + i] = in.take<float>();
        for (int i = 0; i < 2; ++i) half_axes[2 * k + i] = in.take<float>();
        for (int i = 0; i < 2; ++i) fractions[2 * k + i] = in.take<float>();
        bones[k] = in.take<int8_t>() % 8;
        joint_parents[k] = in.take<int8_t>() % 8;
    }
    if (sd_rig_add_sweep(rig, K, centers.data(), orientations.data(), half_axes.data(), bones.data(),
                         joint_parents.data(), fractions.data(), nullptr) == SD_OK) {
        double v = 0;
        if (sd_rig_sweep_rest_volume(rig, 0, &v) != SD_OK || !(v > 0) || !std::isfinite(v)) __builtin_trap();
        const float u[3] = {0.0f, 0.37f, 1.0f};
        float c[9];
        if (sd_rig_evaluate_sweep(rig, 0, 3, u, c, nullptr, nullptr, nullptr, nullptr) != SD_OK) __builtin_trap();
        sdfuzz::require_finite(c, 9);
    }
    sd_rig_destroy(rig);
    return 0;
}
