// Key-ellipse corrections (Sect. 4.2) from arbitrary numbers on the fixed arm rig: set, mute,
// remove, evaluate at any angle, deform a bent pose, and round-trip the rig blob.
#include "fuzz_fixture.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    static const sdfuzz::Arm arm;
    static const std::vector<uint8_t> blob = arm.rig_blob();
    static sd_binding* binding = arm.bind();
    sd_rig* rig = nullptr;
    if (sd_rig_deserialize(blob.data(), static_cast<int64_t>(blob.size()), &rig) != SD_OK) __builtin_trap();
    sdfuzz::Bytes in(data, size);
    const int count = in.take<uint8_t>() % 8;
    for (int c = 0; c < count; ++c) {
        const int32_t sweep = in.take<int8_t>() % 2, key = in.take<int8_t>() % 9;
        const float angle = in.take<float>();
        float values[8];
        for (float& v : values) v = in.take<float>();
        const uint8_t op = in.take<uint8_t>();
        int32_t index = -1;
        sd_rig_set_key_correction(rig, sweep, key, angle, values, op & 1, &index);
        if (op & 2) {
            const int32_t which = in.take<int8_t>() % 4;
            sd_rig_mute_key_correction(rig, sweep, key, which, op & 4);
        }
        if (op & 8) {
            const int32_t which = in.take<int8_t>() % 4;
            sd_rig_remove_key_correction(rig, sweep, key, which);
        }
    }
    float at[8];
    const int32_t key = in.take<uint8_t>() % 7;
    const float angle = in.take<float>();
    if (sd_rig_key_correction_at(rig, 0, key, angle, at) == SD_OK) sdfuzz::require_finite(at, 8);
    sd_deformer* d = nullptr;
    if (sd_deformer_create(rig, binding, &d) == SD_OK) {
        const std::vector<float> pose = sdfuzz::bent_pose(in.take<int8_t>() / 40.0f);
        const int32_t V = sd_binding_vertex_count(binding);
        std::vector<float> out(3 * static_cast<size_t>(V));
        if (sd_deform(d, 3, pose.data(), V, out.data()) == SD_OK) sdfuzz::require_finite(out.data(), out.size());
        sd_deformer_destroy(d);
    }
    int64_t n = 0;
    if (sd_rig_serialize(rig, nullptr, 0, &n) != SD_OK) __builtin_trap();
    std::vector<uint8_t> again(static_cast<size_t>(n));
    if (sd_rig_serialize(rig, again.data(), n, &n) != SD_OK) __builtin_trap();
    sd_rig* back = nullptr;
    if (sd_rig_deserialize(again.data(), n, &back) != SD_OK) __builtin_trap();  // what it wrote, it reads
    sd_rig_destroy(back);
    sd_rig_destroy(rig);
    return 0;
}
