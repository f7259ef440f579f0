#include "deform/shape_key_mix.h"

#include <cstddef>

namespace sd {

int32_t mix_shape_keys(int32_t vertex_count, const float* rest, const float* blocks, const ShapeKeyTerm* terms,
                       int32_t term_count, int32_t* moved, float* moves) {
    const size_t block = 3 * static_cast<size_t>(vertex_count);
    int32_t count = 0;
    for (int32_t v = 0; v < vertex_count; ++v) {
        const size_t at = 3 * static_cast<size_t>(v);
        float d[3];
        for (int c = 0; c < 3; ++c) d[c] = blocks[at + c] - rest[at + c];
        for (int32_t t = 0; t < term_count; ++t) {
            const float* key = blocks + static_cast<size_t>(terms[t].key) * block + at;
            const float* relative = blocks + static_cast<size_t>(terms[t].relative) * block + at;
            for (int c = 0; c < 3; ++c) d[c] += terms[t].value * (key[c] - relative[c]);
        }
        if (d[0] == 0.0f && d[1] == 0.0f && d[2] == 0.0f) continue;
        moved[count] = v;
        for (int c = 0; c < 3; ++c) moves[3 * static_cast<size_t>(count) + c] = d[c];
        ++count;
    }
    return count;
}

}  // namespace sd
