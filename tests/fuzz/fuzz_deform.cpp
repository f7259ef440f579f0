// Deforming with arbitrary poses and volume settings, some vertices displaced, shape keys mixed:
// either an error, or finite results; the frame's values composed from what came out.
#include "fuzz_fixture.h"

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
    sd_deformer_destroy(d);
    return 0;
}
