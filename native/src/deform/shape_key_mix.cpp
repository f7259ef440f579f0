#include "deform/shape_key_mix.h"

#include <cstddef>

namespace sd {

int32_t mix_shape_keys(int32_t vertex_count, const float* rest, const float* blocks, const ShapeKeyTerm* terms,
                       int32_t term_count, int32_t* moved, float* moves) {
    // Every vertex's d first, into `moves` (flat loops that vectorise), then the rows that are
    // not zero moved forward in place (a row only ever moves to a lower index).
    const size_t n = 3 * static_cast<size_t>(vertex_count);
    for (size_t i = 0; i < n; ++i) moves[i] = blocks[i] - rest[i];
    for (int32_t t = 0; t < term_count; ++t) {
        const float* __restrict key = blocks + static_cast<size_t>(terms[t].key) * n;
        const float* __restrict relative = blocks + static_cast<size_t>(terms[t].relative) * n;
        const float value = terms[t].value;
        for (size_t i = 0; i < n; ++i) moves[i] += value * (key[i] - relative[i]);
    }
    int32_t count = 0;
    for (int32_t v = 0; v < vertex_count; ++v) {
        const float* d = moves + 3 * static_cast<size_t>(v);
        if (d[0] == 0.0f && d[1] == 0.0f && d[2] == 0.0f) continue;
        float* to = moves + 3 * static_cast<size_t>(count);
        for (int c = 0; c < 3; ++c) to[c] = d[c];
        moved[count++] = v;
    }
    return count;
}

}  // namespace sd
