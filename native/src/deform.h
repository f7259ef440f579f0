// One frame of sweep-based deformation (Sect. 4.1, 4.4):
//   pose -> key ellipses -> C(t), Q(t) per sweep -> volume control of a(t), b(t)
//        -> every vertex: Σ_sweeps w (S(θ_V, t_V) + R(t_V) d_V) + Σ_bones w M_b V.
#pragma once

#include "bind.h"
#include "linear_blend_skinning.h"
#include "rig.h"

#include <vector>

namespace sd {

/// Everything the vertex kernel needs of one span of one sweep in this frame, in float:
/// C(u) cubic coefficients, the two key quaternions, and the volume controller's change
/// of a(u), b(u) as quadratics per half-span.
struct SpanKernel {
    float c[4][3];
    float q0[4], q1[4];    // x, y, z, w
    float da[2][3], db[2][3];
};

class Deformer {
public:
    /// @throws InvalidInput if the binding does not fit the rig.
    Deformer(Rig rig, Binding binding);

    void set_volume_preservation(bool enabled, double strength);
    /// Per-sweep I_C subtracted from the rest volume to form the controller's target.
    void set_volume_offsets(const std::vector<double>& offsets);

    /// @param pose  #B*16 column-major posed bone matrices. @throws InvalidInput
    /// @param out   #V*3 deformed positions
    void deform(const float* pose, float* out);

    const Rig& rig() const { return rig_; }
    const Binding& binding() const { return binding_; }
    int vertex_count() const { return binding_.vertex_count(); }

    // Figures of the last frame, per sweep.
    std::vector<double> volume_before, volume_after;
    std::vector<int> volume_iterations;

private:
    void prepare_sweeps(const SkeletonPose& pose);

    Rig rig_;
    Binding binding_;
    std::vector<int> span_base_;       // first SpanKernel of each sweep
    std::vector<int32_t> kernel_span_;  // per sweep influence: global span index
    bool volume_enabled_ = true;
    double volume_strength_ = 1.0;
    std::vector<double> volume_offsets_;

    // Per-frame scratch, kept to avoid allocating every frame.
    SkeletonPose pose_;
    std::vector<SpanKernel> spans_;
    std::vector<Affine3x4> bones_;
};

}  // namespace sd
