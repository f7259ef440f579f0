// Deforming with arbitrary poses and volume settings, some vertices displaced, shape keys mixed:
// either an error, or finite results; the frame's values composed from what came out; and the
// same frame in one pass (sd_deform_frame) equal to the separate calls to the bit, or refused
// as they are with nothing written.
#include "fuzz_fixture.h"

#include <cstring>

namespace {

/// An output check of the arm's ring mesh: each ring on the bone it lies along.
sd_output_check* ring_check(const sdfuzz::Arm& arm, sd_binding* binding) {
    const int32_t V = sd_binding_vertex_count(binding);
    std::vector<float> rest(3 * static_cast<size_t>(V)), lengths = {1.0f, 1.0f, 0.3f}, weights(V, 1.0f);
    std::vector<int32_t> bones(V);
    sd_deformer* d = nullptr;
    if (sd_deformer_create(arm.rig, binding, &d) != SD_OK || sd_deform(d, 3, arm.rest, V, rest.data()) != SD_OK)
        __builtin_trap();
    sd_deformer_destroy(d);
    for (int32_t v = 0; v < V; ++v) bones[v] = rest[3 * v] < 1.0f ? 0 : (rest[3 * v] < 2.0f ? 1 : 2);
    sd_output_check* c = nullptr;
    if (sd_output_check_create(V, rest.data(), 3, arm.rest, lengths.data(), 1, bones.data(), weights.data(), 0.05f,
                               &c) != SD_OK)
        __builtin_trap();
    return c;
}

bool same_bits(const std::vector<float>& a, const std::vector<float>& b) {
    return a.size() == b.size() && (a.empty() || std::memcmp(a.data(), b.data(), a.size() * sizeof(float)) == 0);
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    static const sdfuzz::Arm arm;
    static sd_binding* binding = arm.bind();
    // A fresh deformer per input, so that a crash replays from its input alone.
    sd_deformer* d = nullptr;
    if (sd_deformer_create(arm.rig, binding, &d) != SD_OK) __builtin_trap();
    sdfuzz::Bytes in(data, size);
    const int enabled = in.take<uint8_t>() & 1;  // (read in this order: argument order is unspecified)
    const float strength = in.take<float>();
    sd_deformer_set_volume_preservation(d, enabled, strength);
    float offsets[1] = {in.take<float>()};
    sd_deformer_set_volume_offsets(d, 1, offsets);
    float pose[48];
    for (int i = 0; i < 48; ++i) {
        const uint8_t mode = in.take<uint8_t>();
        pose[i] = mode < 128 ? arm.rest[i] + in.take<int8_t>() / 32.0f : in.take<float>();
    }
    const int32_t V = sd_binding_vertex_count(binding);
    std::vector<float> out(3 * static_cast<size_t>(V));
    if (sd_deform(d, 3, pose, V, out.data()) == SD_OK) sdfuzz::require_finite(out.data(), out.size());
    // The same pose with some vertices displaced (shape keys): an error, or finite both.
    std::vector<int32_t> moved;
    std::vector<float> moves;
    for (int32_t v = 0; v < V; ++v) {
        const uint8_t mode = in.take<uint8_t>();
        if (mode < 64) continue;
        moved.push_back(mode < 80 ? V - 1 - v : v);  // sometimes out of order
        for (int c = 0; c < 3; ++c) moves.push_back(mode < 192 ? in.take<int8_t>() / 64.0f : in.take<float>());
    }
    std::vector<float> turned(moves.size());
    if (sd_deform_displaced(d, 3, pose, V, static_cast<int32_t>(moved.size()), moved.data(), moves.data(), out.data(),
                            turned.data()) == SD_OK) {
        sdfuzz::require_finite(out.data(), out.size());
        sdfuzz::require_finite(turned.data(), turned.size());
    }
    // Shape keys mixed from the same bytes: the mesh as reference, two more blocks, two terms.
    std::vector<float> blocks(3 * out.size());
    for (size_t i = 0; i < blocks.size(); ++i) {
        const uint8_t mode = in.take<uint8_t>();
        blocks[i] = out[i % out.size()] + (mode < 200 ? in.take<int8_t>() / 64.0f : in.take<float>());
    }
    const int32_t terms[4] = {in.take<int8_t>() % 4, in.take<int8_t>() % 4, in.take<int8_t>() % 4,
                              in.take<int8_t>() % 4};
    const float values[2] = {in.take<float>(), in.take<float>()};
    int32_t count = -1;
    std::vector<int32_t> mixed(static_cast<size_t>(V));
    std::vector<float> mixed_moves(out.size());
    if (sd_mix_shape_keys(V, out.data(), 3, blocks.data(), 2, terms, values, &count, mixed.data(),
                          mixed_moves.data()) == SD_OK) {
        if (count < 0 || count > V) __builtin_trap();
        sdfuzz::require_finite(mixed_moves.data(), 3 * static_cast<size_t>(count));
    }
    // The frame's values composed from the same arrays (the moved list as it came: sometimes
    // out of order, refused), into a buffer of its own and in place.
    std::vector<float> composed(out.size());
    const int32_t M = static_cast<int32_t>(moved.size());
    const bool with_base = in.take<uint8_t>() & 1;
    if (sd_compose_offsets(V, out.data(), blocks.data(), with_base ? out.data() : nullptr, M, moved.data(),
                           turned.data(), moves.data(), composed.data()) == SD_OK)
        sd_compose_offsets(V, out.data(), blocks.data(), nullptr, M, moved.data(), turned.data(), nullptr, out.data());
    // The frame in one pass against the three calls: displaced, checked, composed.
    static sd_output_check* check = ring_check(arm, binding);
    const float limit = in.take<uint8_t>() < 200 ? 0.5f + in.take<uint8_t>() / 32.0f : in.take<float>();
    const float* rest = blocks.data();
    const float* base = with_base ? blocks.data() + out.size() : nullptr;
    const bool subtract = in.take<uint8_t>() & 1;
    std::vector<float> p1(out.size()), t1(turned.size()), c1(out.size());
    int32_t beyond1 = 0, vertex1 = -1, bone1 = -1;
    float ratio1 = 0.0f;
    const bool separate =
        sd_deform_displaced(d, 3, pose, V, M, moved.data(), moves.data(), p1.data(), t1.data()) == SD_OK &&
        sd_output_check_run(check, 3, pose, V, p1.data(), limit, &beyond1, &ratio1, &vertex1, &bone1, nullptr) ==
            SD_OK &&
        sd_compose_offsets(V, p1.data(), rest, base, M, moved.data(), t1.data(), subtract ? moves.data() : nullptr,
                           c1.data()) == SD_OK;
    std::vector<float> p2(out.size(), 7.0f), t2(turned.size(), 7.0f), c2(out.size(), 7.0f);
    int32_t beyond2 = 0, vertex2 = -1, bone2 = -1;
    float ratio2 = 0.0f;
    const bool one_pass =
        sd_deform_frame(d, 3, pose, V, M, moved.data(), moves.data(), p2.data(), t2.data(), check, limit, &beyond2,
                        &ratio2, &vertex2, &bone2, rest, base, subtract ? 1 : 0, c2.data()) == SD_OK;
    if (one_pass != separate) __builtin_trap();
    if (one_pass) {
        if (!same_bits(p1, p2) || !same_bits(t1, t2) || !same_bits(c1, c2)) __builtin_trap();
        if (beyond1 != beyond2 || vertex1 != vertex2 || bone1 != bone2 ||
            std::memcmp(&ratio1, &ratio2, sizeof(float)) != 0)
            __builtin_trap();
    } else {
        for (const std::vector<float>* a : {&p2, &t2, &c2})
            for (const float x : *a)
                if (x != 7.0f) __builtin_trap();
    }
    sd_deformer_destroy(d);
    return 0;
}
