// The per-vertex half of a frame, laid out for SIMD.
//
// Every sweep influence of every vertex evaluates w (C(u) + R(u) (x + Δa cosθ, y + Δb sinθ, z))
// with C, R, Δa, Δb polynomials of its half-span. Sorting the influences by half-span turns
// that into long loops over structure-of-arrays with the half-span's coefficients held
// constant, which the compiler vectorises; a second pass sums each vertex's contributions
// and its bone influences in a fixed order (results independent of the thread count).
#pragma once

#include "bind/bind.h"
#include "deform/linear_blend_skinning.h"

#include <cstdint>
#include <vector>

namespace sd {

/// One half of one span of one sweep in this frame, in float: C(u) cubic coefficients, the
/// span's two key quaternions, and the volume controller's change of a(u), b(u).
struct HalfSpanKernel {
    float c[4][3];
    float q0[4], q1[4];  // x, y, z, w
    float da[3], db[3];
};

class SweepKernel {
public:
    SweepKernel() = default;
    /// @param span_base  first span of each sweep in the frame's half-span array (which holds
    ///                   2 entries per span: halves u < 0.5 and u >= 0.5)
    SweepKernel(const Binding& binding, const std::vector<int>& span_base);

    /// out[v] = Σ sweep contributions + Σ_b w_b M_b rest[v], for every vertex (#V*3).
    void run(const HalfSpanKernel* half_spans, const Affine3x4* bones, const Binding& binding, float* out);

private:
    struct Batch {
        int32_t half_span, begin, end;
    };
    std::vector<Batch> batches_;                        // ranges of one half-span, <= kBatch long
    std::vector<float> u_, w_, x_, y_, z_, cos_, sin_;  // influences sorted by half-span
    std::vector<float> px_, py_, pz_;                   // per-frame weighted contributions
    std::vector<uint32_t> row_offsets_, rows_;          // vertex -> its sorted influence slots
};

}  // namespace sd
