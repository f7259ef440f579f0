// Holding the joints' volume on the arm's ring mesh with triangles from the input (corners
// anywhere, fewer triangles, another vertex count), then a frame; and a second deformer of the
// same rig taking the first one's tables: either an error that changes nothing, or finite frames,
// the two deformers' bit for bit the same. Then the tables through their blob, some of its
// payload's bytes changed from the input and its checksum made right again (so that the reader
// sees them): a blob left whole deforms as the first deformer, any other is refused or deforms
// to finite positions. Last the same triangles and pose for a thick tube's trunk fill: refused
// triangles change nothing, others give finite frames, and so does a deformer filled as it.
#include "fuzz_fixture.h"

#include <cstring>
#include <vector>

namespace {

uint32_t crc32(const uint8_t* p, size_t n) {
    uint32_t c = 0xFFFFFFFFu;
    for (size_t i = 0; i < n; ++i) {
        c ^= p[i];
        for (int k = 0; k < 8; ++k) c = (c & 1) ? 0xEDB88320u ^ (c >> 1) : c >> 1;
    }
    return c ^ 0xFFFFFFFFu;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    static const sdfuzz::Arm arm;
    static sd_binding* binding = arm.bind();
    static const std::vector<int32_t> rings = sdfuzz::Arm::ring_triangles();
    sd_deformer *d = nullptr, *copy = nullptr;
    if (sd_deformer_create(arm.rig, binding, &d) != SD_OK || sd_deformer_create(arm.rig, binding, &copy) != SD_OK)
        __builtin_trap();
    sdfuzz::Bytes in(data, size);
    const int32_t V = sd_binding_vertex_count(binding);
    std::vector<int32_t> tris = rings;
    const int edits = in.take<uint8_t>() % 8;
    for (int i = 0; i < edits; ++i) {
        const size_t at = in.take<uint16_t>() % tris.size();  // (read in this order)
        tris[at] = in.take<int32_t>();
    }
    const int32_t count = static_cast<int32_t>(tris.size() / 3) - in.take<uint8_t>() % 4;
    const int32_t vertices = V + (in.take<uint8_t>() == 0xA5 ? 1 : 0);
    int32_t held = -1;
    if (sd_deformer_hold_joint_volumes(d, vertices, count, tris.data(), &held) == SD_OK && (held < 0 || held > 2))
        __builtin_trap();
    if (sd_deformer_hold_joint_volumes_of(copy, d, &held) != SD_OK) __builtin_trap();
    float pose[48];
    for (int i = 0; i < 48; ++i) {
        const uint8_t mode = in.take<uint8_t>();
        pose[i] = mode < 128 ? arm.rest[i] + in.take<int8_t>() / 32.0f : in.take<float>();
    }
    std::vector<float> out(3 * static_cast<size_t>(V)), again(out.size());
    const sd_status a = sd_deform(d, 3, pose, V, out.data()), b = sd_deform(copy, 3, pose, V, again.data());
    if (a != b) __builtin_trap();
    if (a == SD_OK) {
        sdfuzz::require_finite(out.data(), out.size());
        if (out != again) __builtin_trap();
    }
    int64_t n = 0;
    if (sd_deformer_serialize_joint_volumes(d, nullptr, 0, &n) != SD_OK) __builtin_trap();
    std::vector<uint8_t> blob(static_cast<size_t>(n));
    if (sd_deformer_serialize_joint_volumes(d, blob.data(), n, &n) != SD_OK || n < 20) __builtin_trap();
    const size_t header = 16, payload = blob.size() - header - 4;
    const int changes = in.take<uint8_t>() % 4;
    for (int i = 0; i < changes && payload > 0; ++i) {
        const size_t at = header + in.take<uint16_t>() % payload;  // (read in this order)
        blob[at] = in.take<uint8_t>();
    }
    const uint32_t crc = crc32(blob.data() + header, payload);
    std::memcpy(blob.data() + header + payload, &crc, 4);
    sd_deformer* loaded = nullptr;
    if (sd_deformer_create(arm.rig, binding, &loaded) != SD_OK) __builtin_trap();
    const sd_status l = sd_deformer_load_joint_volumes(loaded, blob.data(), n, &held);
    if (changes == 0 && l != SD_OK) __builtin_trap();
    if (l == SD_OK && sd_deform(loaded, 3, pose, V, again.data()) == SD_OK) {
        sdfuzz::require_finite(again.data(), again.size());
        if (changes == 0 && a == SD_OK && out != again) __builtin_trap();
    }
    sd_deformer_destroy(loaded);
    sd_deformer_destroy(copy);
    sd_deformer_destroy(d);

    // The arm's bones with a sweep as thick as a trunk: its keys follow blends of the bones, so
    // its skin is filled.
    static const sdfuzz::Arm tube(0.6f, 0.5f, 0.0f);
    static sd_binding* tube_binding = tube.bind();
    sd_deformer *filled = nullptr, *follower = nullptr, *plain = nullptr;
    if (sd_deformer_create(tube.rig, tube_binding, &filled) != SD_OK ||
        sd_deformer_create(tube.rig, tube_binding, &follower) != SD_OK ||
        sd_deformer_create(tube.rig, tube_binding, &plain) != SD_OK)
        __builtin_trap();
    const sd_status t = sd_deformer_set_skin_triangles(filled, vertices, count, tris.data());
    if (sd_deformer_fill_trunk_as(follower, filled) != SD_OK) __builtin_trap();
    std::vector<float> f(out.size()), g(out.size()), p(out.size());
    const sd_status fa = sd_deform(filled, 3, pose, V, f.data()), fb = sd_deform(follower, 3, pose, V, g.data()),
                    fc = sd_deform(plain, 3, pose, V, p.data());
    if (fa != fc || fb != fc) __builtin_trap();
    if (fa == SD_OK) {
        sdfuzz::require_finite(f.data(), f.size());
        sdfuzz::require_finite(g.data(), g.size());
        if (t != SD_OK && (f != p || g != p)) __builtin_trap();  // refused: nothing changed
    }
    sd_deformer_destroy(plain);
    sd_deformer_destroy(follower);
    sd_deformer_destroy(filled);
    return 0;
}
