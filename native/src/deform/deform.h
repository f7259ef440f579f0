// One frame of sweep-based deformation (Sect. 4.1, 4.4):
//   pose -> key ellipses -> C(t), Q(t) per sweep -> volume control of a(t), b(t)
//        -> every vertex: Σ_sweeps w (S(θ_V, t_V) + R(t_V) d_V) + Σ_bones w M_b V.
#pragma once

#include "bind/bind.h"
#include "deform/linear_blend_skinning.h"
#include "rig/rig.h"
#include "deform/sweep_kernel.h"

#include <vector>

namespace sd {

/// Thick chains (Sweep::bends_smoothly): scales each key's half-axes by the square root of
/// how much shorter the posed sweep is than the rest sweep around the key (along its
/// normals, the mean over its two spans), blended by `strength`. The volume controller then
/// corrects what is left.
void restore_local_volume(const Sweep& sweep, const SweepGeometry& posed, double strength, std::vector<double>& a,
                          std::vector<double>& b);

class Deformer {
public:
    /// @throws InvalidInput if the binding does not fit the rig.
    Deformer(Rig rig, Binding binding);

    void set_volume_preservation(bool enabled, double strength);
    /// Per-sweep I_C subtracted from the rest volume to form the controller's target.
    void set_volume_offsets(const std::vector<double>& offsets);
    /// Replaces the key-ellipse corrections (Sect. 4.2) of the deformer's rig; the binding
    /// stays valid (it was made against the uncorrected rest sweeps). @throws InvalidInput
    void set_corrections(const std::vector<CorrectionRecord>& records) { rig_.set_corrections(records); }

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
    std::vector<int> span_base_;  // first span of each sweep
    SweepKernel kernel_;
    bool volume_enabled_ = true;
    double volume_strength_ = 1.0;
    std::vector<double> volume_offsets_;

    // Kept from frame to frame: the posed skeleton, the half-spans' coefficients (sized once,
    // in the constructor) and the bones' affine maps. A frame still allocates: bone_affines()
    // returns a new vector, and prepare_sweeps() builds per sweep the posed keys, the
    // half-axes, the sweep's geometry and volume form, and the half-axis changes.
    SkeletonPose pose_;
    std::vector<HalfSpanKernel> half_spans_;  // 2 per span
    std::vector<Affine3x4> bones_;
};

}  // namespace sd
