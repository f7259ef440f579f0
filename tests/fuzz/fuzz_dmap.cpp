// The displacement map (libsweepdeform_dmap): fitted from the arm's rig blob and a binding
// blob the fuzzer may damage, any grid, then points bound through it; a binding blob it
// returns must load in libsweepdeform and deform.
#include "fuzz_fixture.h"
#include "sweepdeform/sweepdeform_dmap.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    static const sdfuzz::Arm arm;
    static const std::vector<uint8_t> rig_blob = arm.rig_blob();
    static const std::vector<uint8_t> binding_blob = arm.binding_blob();
    static const std::vector<int32_t> tris = sdfuzz::Arm::ring_triangles();
    sdfuzz::Bytes in(data, size);
    std::vector<uint8_t> bb = binding_blob;
    const int flips = in.take<uint8_t>() % 4;  // usually none: the map's own failure modes first
    for (int i = 0; i < flips; ++i) {
        const size_t at = in.take<uint16_t>() % bb.size();
        bb[at] ^= in.take<uint8_t>();
    }
    // Grids up to 64 x 16 (and out of range): the largest legal grids (256 x 64) take a minute
    // a fit under ASan, which would leave no time for anything else.
    const int32_t theta = in.take<int16_t>() % 80;
    const int32_t tcells = in.take<int8_t>() % 20;
    const float smoothing = in.take<uint8_t>() < 200 ? -1.0f : in.take<float>();
    sd_displacement_map* map = nullptr;
    if (sd_dmap_fit(rig_blob.data(), static_cast<int64_t>(rig_blob.size()), bb.data(), static_cast<int64_t>(bb.size()),
                    static_cast<int32_t>(tris.size() / 3), tris.data(), theta, tcells, smoothing, &map) != SD_OK)
        return 0;
    const int32_t N = 1 + in.take<uint8_t>() % 32;
    std::vector<float> pts(3 * static_cast<size_t>(N));
    for (int i = 0; i < N; ++i) {
        const bool raw = in.take<uint8_t>() >= 230;
        pts[3 * i] = raw ? in.take<float>() : in.take<uint8_t>() / 110.0f;
        pts[3 * i + 1] = raw ? in.take<float>() : in.take<int8_t>() / 1000.0f;
        pts[3 * i + 2] = raw ? in.take<float>() : in.take<int8_t>() / 1000.0f;
    }
    sd_dmap_binding* out = nullptr;
    int32_t snapped = 0;
    if (sd_dmap_bind(map, N, pts.data(), in.take<float>(), &snapped, &out) == SD_OK) {
        int64_t n = 0;  // the blob: size query, then fill
        if (sd_dmap_binding_serialize(out, nullptr, 0, &n) != SD_OK) __builtin_trap();
        std::vector<uint8_t> bytes(static_cast<size_t>(n));
        if (sd_dmap_binding_serialize(out, bytes.data(), n, &n) != SD_OK) __builtin_trap();
        sd_binding* b = nullptr;
        if (sd_binding_deserialize(bytes.data(), n, &b) != SD_OK) __builtin_trap();  // its own blob must load
        sd_deformer* d = nullptr;
        if (sd_deformer_create(arm.rig, b, &d) != SD_OK) __builtin_trap();
        std::vector<float> moved(pts.size());
        if (sd_deform(d, 3, arm.rest, N, moved.data()) == SD_OK) sdfuzz::require_finite(moved.data(), moved.size());
        sd_deformer_destroy(d);
        sd_binding_destroy(b);
        sd_dmap_binding_destroy(out);
    }
    sd_dmap_destroy(map);
    return 0;
}
