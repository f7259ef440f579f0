// The values a frame leaves for Blender, composed in one pass: the add-on's last arithmetic
// before it writes a carrier (addon/.../blender/frame.py). Made one array at a time in numpy
// it was three passes over the mesh and a scatter, a tenth of a 75K-vertex frame.
#pragma once

#include <cstdint>

namespace sd {

/// out[v] = base[v] + (positions[v] − rest[v]) (without base when it is null), then for each
/// i < moved_count: out[moved[i]] += turned[i] − displacements[i] (+= turned[i] when
/// displacements is null). Each sum is one float32 operation in that order, so the result is
/// the same to the bit as those sums made one array at a time. `out` may be any of the
/// vertex arrays (each element is read before it is written). Inputs are trusted (the ABI
/// checks them); `moved` strictly ascending within [0, vertex_count). Parallel (TBB).
void compose_frame_offsets(int32_t vertex_count, const float* positions, const float* rest, const float* base,
                           int32_t moved_count, const int32_t* moved, const float* turned, const float* displacements,
                           float* out);

/// compose_frame_offsets for the vertices [begin, end) alone, on the calling thread.
void compose_frame_offsets_range(int32_t begin, int32_t end, const float* positions, const float* rest,
                                 const float* base, int32_t moved_count, const int32_t* moved, const float* turned,
                                 const float* displacements, float* out);

}  // namespace sd
