// Anatomical effects from arbitrary settings on the fixed arm: joints (any bone, kind,
// flexion direction), effects, parameters, a proxy mesh of arbitrary numbers, then a frame.
#include "fuzz_fixture.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    static const sdfuzz::Arm arm;
    static sd_binding* binding = arm.bind();
    static const std::vector<int32_t> tris = sdfuzz::Arm::ring_triangles();
    sd_anatomy* an = nullptr;
    if (sd_anatomy_create(arm.rig, binding, static_cast<int32_t>(tris.size() / 3), tris.data(), &an) != SD_OK)
        __builtin_trap();
    sdfuzz::Bytes in(data, size);
    const int joints = in.take<uint8_t>() % 3;
    for (int j = 0; j < joints; ++j) {
        float dir[3];
        for (float& x : dir) x = in.take<uint8_t>() < 200 ? in.take<int8_t>() / 64.0f : in.take<float>();
        int32_t index = -1;
        const int32_t bone = in.take<int8_t>() % 4, kind = in.take<int8_t>() % 4;  // (read in this order)
        if (sd_anatomy_add_joint(an, bone, kind, dir, &index) != SD_OK) continue;
        sd_anatomy_set_joint_effects(an, index, in.take<int8_t>() % 9);
        const int params = in.take<uint8_t>() % 4;
        for (int p = 0; p < params; ++p) {
            const int32_t which = in.take<int8_t>() % 8;
            const float value = in.take<float>();
            sd_anatomy_set_joint_parameter(an, index, which, value);
        }
        if (in.take<uint8_t>() & 1) {  // a proxy of the fuzzer's: up to 12 points, 16 triangles
            const int32_t N = in.take<uint8_t>() % 13, F = in.take<uint8_t>() % 17;
            std::vector<float> p(3 * static_cast<size_t>(N));
            for (float& x : p) x = in.take<int8_t>() / 256.0f;
            std::vector<int32_t> f(3 * static_cast<size_t>(F));
            for (int32_t& x : f) x = in.take<int8_t>() % (N + 1);
            const float fraction = in.take<float>();
            sd_anatomy_set_joint_proxy(an, index, N, p.data(), F, f.data(), fraction);
        }
    }
    const int32_t mode = in.take<int8_t>() % 4, restore = in.take<uint8_t>() & 1;
    sd_anatomy_set_volume_feedback(an, mode, restore);
    sd_deformer* d = nullptr;
    if (sd_deformer_create(arm.rig, binding, &d) != SD_OK) __builtin_trap();
    const std::vector<float> pose = sdfuzz::bent_pose(in.take<int8_t>() / 40.0f);
    const int32_t V = sd_binding_vertex_count(binding);
    std::vector<float> out(3 * static_cast<size_t>(V));
    for (int frame = 0; frame < 2; ++frame)  // the volume feedback carries into the next frame
        if (sd_deform_with_anatomy(d, an, 3, pose.data(), V, out.data()) == SD_OK)
            sdfuzz::require_finite(out.data(), out.size());
    sd_deformer_destroy(d);
    sd_anatomy_destroy(an);
    return 0;
}
