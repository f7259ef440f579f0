#include "deform/frame_offsets.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cstddef>

namespace sd {

void compose_frame_offsets_range(int32_t begin, int32_t end, const float* positions, const float* rest,
                                 const float* base, int32_t moved_count, const int32_t* moved, const float* turned,
                                 const float* displacements, float* out) {
    const size_t b = 3 * static_cast<size_t>(begin), e = 3 * static_cast<size_t>(end);
    if (base) {
        for (size_t i = b; i < e; ++i) out[i] = base[i] + (positions[i] - rest[i]);
    } else {
        for (size_t i = b; i < e; ++i) out[i] = positions[i] - rest[i];
    }
    // (the moved vertices ascend, so the range's are one run)
    const int32_t* first = std::lower_bound(moved, moved + moved_count, begin);
    const int32_t* last = std::lower_bound(first, moved + moved_count, end);
    for (const int32_t* m = first; m != last; ++m) {
        const size_t i = static_cast<size_t>(m - moved);
        float* o = out + 3 * static_cast<size_t>(*m);
        const float* t = turned + 3 * i;
        if (displacements) {
            const float* d = displacements + 3 * i;
            for (int c = 0; c < 3; ++c) o[c] += t[c] - d[c];
        } else {
            for (int c = 0; c < 3; ++c) o[c] += t[c];
        }
    }
}

void compose_frame_offsets(int32_t vertex_count, const float* positions, const float* rest, const float* base,
                           int32_t moved_count, const int32_t* moved, const float* turned, const float* displacements,
                           float* out) {
    // In blocks of vertices on the threads, each block adding its own moved vertices' turns
    // while its lines are in cache.
    constexpr int32_t kGrain = 8192;
    tbb::parallel_for(tbb::blocked_range<int32_t>(0, vertex_count, kGrain), [&](const tbb::blocked_range<int32_t>& r) {
        compose_frame_offsets_range(r.begin(), r.end(), positions, rest, base, moved_count, moved, turned,
                                    displacements, out);
    });
}

}  // namespace sd
