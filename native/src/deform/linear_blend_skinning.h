// Linear blend skinning: the bone-driven parts of a character (hands, feet, head), and the
// reference kernel the benchmark compares the sweep deformation against.
#pragma once

#include "rig/skeleton.h"

#include <cstdint>
#include <vector>

namespace sd {

/// A bone's deformation as a float 3x4 matrix (rows), the layout the vertex kernels use.
struct Affine3x4 {
    float m[3][4];
    void apply_add(float w, const float* p, float* out) const {
        for (int r = 0; r < 3; ++r) out[r] += w * (m[r][0] * p[0] + m[r][1] * p[1] + m[r][2] * p[2] + m[r][3]);
    }
    /// this += w other, element by element (blending matrices before applying them).
    void add_weighted(float w, const Affine3x4& other) {
        float* a = &m[0][0];
        const float* o = &other.m[0][0];
        for (int k = 0; k < 12; ++k) a[k] += w * o[k];
    }
};

/// M_b = P_b rest_b^-1 of every bone as 3x4 floats.
std::vector<Affine3x4> bone_affines(const SkeletonPose& pose);

/// Reference kernel: out[v] = sum_i w[v,i] M[j[v,i]] rest[v], 4 influences per vertex,
/// parallel over vertices (TBB). Inputs are trusted (the benchmark's own data).
void skin_linear_blend4(const std::vector<Affine3x4>& bones, int vertex_count, const float* rest, const int32_t* joints,
                        const float* weights, float* out);

}  // namespace sd
