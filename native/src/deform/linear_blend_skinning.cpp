#include "deform/linear_blend_skinning.h"

#include "math/flush_denormals.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

namespace sd {

std::vector<Affine3x4> bone_affines(const SkeletonPose& pose) {
    std::vector<Affine3x4> out(pose.deform.size());
    for (size_t b = 0; b < out.size(); ++b)
        for (int r = 0; r < 3; ++r)
            for (int c = 0; c < 4; ++c) out[b].m[r][c] = static_cast<float>(pose.deform[b][c][r]);
    return out;
}

void skin_linear_blend4(const std::vector<Affine3x4>& bones, int V, const float* rest, const int32_t* joints,
                        const float* weights, float* out) {
    tbb::parallel_for(tbb::blocked_range<int>(0, V, 2048), [&](const tbb::blocked_range<int>& r) {
        const FlushDenormals flush;  // flush_denormals.h
        for (int v = r.begin(); v != r.end(); ++v) {
            // Blend the matrices first (12 multiply-adds per influence), then apply once:
            // the usual GPU/real-time formulation.
            float m[12] = {0};
            for (int i = 0; i < 4; ++i) {
                const float w = weights[4 * v + i];
                const float* b = &bones[joints[4 * v + i]].m[0][0];
                for (int k = 0; k < 12; ++k) m[k] += w * b[k];
            }
            const float* p = rest + 3 * v;
            for (int row = 0; row < 3; ++row)
                out[3 * v + row] = m[4 * row] * p[0] + m[4 * row + 1] * p[1] + m[4 * row + 2] * p[2] + m[4 * row + 3];
        }
    });
}

}  // namespace sd
