// The BVH reader (sweepdeform_io, the command-line tool's): arbitrary text either parses into a
// clip whose every frame gives finite matrices, or throws std::exception; nothing else.
#include <sweepdeform_io/bvh.h>

#include <cmath>
#include <cstdint>
#include <exception>
#include <string_view>

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    try {
        const sd::io::BvhClip clip =
            sd::io::parse_bvh(std::string_view(reinterpret_cast<const char*>(data), size), "fuzz.bvh");
        for (int f = -1; f < clip.frame_count && f < 4; ++f)
            for (float x : sd::io::bvh_global_matrices(clip, f))
                if (std::isnan(x)) return 0;  // NaN channels are the caller's to refuse (the tool does)
    } catch (const std::exception&) {}
    return 0;
}
