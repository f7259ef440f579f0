// One frame of sweep-based deformation (Sect. 4.1, 4.4):
//   pose -> key ellipses -> C(t), Q(t) per sweep -> volume control of a(t), b(t)
//        -> every vertex: Σ_sweeps w (S(θ_V, t_V) + R(t_V) d_V) + Σ_bones w M_b V.
#pragma once

#include "bind/bind.h"
#include "deform/joint_volume.h"
#include "deform/linear_blend_skinning.h"
#include "rig/rig.h"
#include "deform/sweep_kernel.h"
#include "deform/trunk_fill.h"

#include <array>
#include <functional>
#include <memory>
#include <mutex>
#include <vector>

namespace sd {

/// Length of a sweep along its normals over one span: the chord times the mean of <N, T> at
/// both ends (the volume's density per unit area, Sect. 4.4, integrated coarsely): what
/// restore_local_volume compares with the rest sweep's.
double span_thickness(const SweepGeometry& g, int span);

/// Thick chains (Sweep::bends_smoothly) in `posed` with half-axes a, b: the share of their
/// restored volume that may go to the inside of the bend, 1 while the sweep bends gently for
/// its depth, falling to 0 where it bends so sharply that its planes close in on its inside
/// edge (see deform.cpp, sweep_folding).
double folding_hold(const Sweep& sweep, const SweepGeometry& posed, const std::vector<double>& a,
                    const std::vector<double>& b);

/// Thick chains (Sweep::bends_smoothly): grows each key's cross-section by how much shorter
/// the posed sweep is than the rest sweep around the key (along its normals, the mean over its
/// two spans, spread along the sweep by rest arc length), blended by `strength`: a share
/// towards the inside of the bend (scaled by `hold`, folding_hold of the same pose and
/// half-axes), the key moved by shifts[k] so that its outside stays in place, the rest along
/// the bend's axis. The volume controller then adds what is left, and takes nothing back.
/// @param shifts  #K output, armature space
/// @return whether any key moved (shifts not all zero)
bool restore_local_volume(const Sweep& sweep, const SweepGeometry& posed, double strength, double hold,
                          std::vector<double>& a, std::vector<double>& b, std::vector<dvec3>& shifts);

/// Limbs: after the volume controller grew keys from a_before, b_before to a, b, moves each
/// grown key away from the inside of the bend by half its growth along that direction (the
/// fold inside the bend gets a quarter of it). Shrunk half-axes move nothing.
void hold_growth_off_the_fold(const Sweep& sweep, const SweepGeometry& posed, const std::vector<double>& a_before,
                              const std::vector<double>& b_before, const std::vector<double>& a,
                              const std::vector<double>& b, std::vector<dvec3>& centers);

/// Thread safety: every member that reads or writes the per-frame state (deform, the
/// setters) holds the deformer's lock, so two threads may call them on the same deformer at
/// once (a render and the viewport): the calls run one after the other, each with the
/// settings it was given. A caller that must keep several calls together (set offsets, then
/// deform) holds lock() around them; the lock is recursive.
class Deformer {
public:
    /// @throws InvalidInput if the binding does not fit the rig.
    Deformer(Rig rig, Binding binding);

    void set_volume_preservation(bool enabled, double strength);
    /// Per-sweep I_C subtracted from the rest volume to form the controller's target.
    void set_volume_offsets(const std::vector<double>& offsets);
    bool volume_enabled() const { return volume_enabled_; }
    double volume_strength() const { return volume_strength_; }
    const std::vector<double>& volume_offsets() const { return volume_offsets_; }
    /// Each frame, after the controller, grows a limb sweep's keys at each joint by what the
    /// joint's table says the mesh loses in the pose (joint_volume.h; none until given).
    /// @throws InvalidInput
    void set_joint_volumes(std::vector<JointVolumeTable> tables);
    const std::vector<JointVolumeTable>& joint_volumes() const { return joint_volumes_; }
    /// The bound mesh's triangles (#T*3 vertex indices; empty: none): with them a bent trunk's
    /// volume is put back by filling its skin out from the spine (trunk_fill.h) instead of
    /// growing its sweep's sections. @throws InvalidInput
    void set_skin_triangles(const std::vector<int32_t>& triangles);
    /// Fills the trunk as `source` does (same rig): a mesh bound through source's displacement
    /// map raises its skin to the level source's skin reaches each frame (a copy of source's
    /// trunk skin is deformed for it), so that the two stay together. A source that fills no
    /// trunk: none. @throws InvalidInput if the rigs differ
    void fill_trunk_as(const Deformer& source);
    bool fills_trunk() const { return !trunk_fill_.empty(); }
    /// Replaces the key-ellipse corrections (Sect. 4.2) of the deformer's rig; the binding
    /// stays valid (it was made against the uncorrected rest sweeps). @throws InvalidInput
    void set_corrections(const std::vector<CorrectionRecord>& records) {
        const std::lock_guard<std::recursive_mutex> guard(mutex_);
        rig_.set_corrections(records);
    }

    /// Holds the deformer for a sequence of calls (see the class comment).
    std::unique_lock<std::recursive_mutex> lock() const { return std::unique_lock<std::recursive_mutex>(mutex_); }

    /// @param pose  #B*16 column-major posed bone matrices. @throws InvalidInput
    /// @param out   #V*3 deformed positions
    void deform(const float* pose, float* out);

    /// deform(), and for every vertex the local linear map J of its deformation (#V*9 floats
    /// in three blocks of #V*3, block r holding row r of every vertex's J; armature space): Σ_sweeps w R(u) R_rest(u)^T + Σ_bones w M_b (linear
    /// part), blended with the weights the positions are. R(u) is the frame of the vertex's
    /// cross-section at its sweep parameter u in the pose, R_rest(u) at rest: a point moved off
    /// the rest surface by δ within its cross-section's plane deforms to out + J δ (the
    /// cross-section's half-axis changes of the volume control are added, not scaled, so they
    /// do not enter J). The rest pose gives the identity.
    void deform_frames(const float* pose, float* out, float* frames);

    /// deform(), and the displacement d of each of `count` distinct vertices `moved` (#M*3 in
    /// `displacements`, armature space: where a shape key put it, relative to the bound rest)
    /// turned by the vertex's J into `turned` (#M*3): the displaced vertex deforms to
    /// out + turned. The same J as deform_frames, assembled for those vertices only.
    void deform_displaced(const float* pose, int32_t count, const int32_t* moved, const float* displacements,
                          float* out, float* turned);

    /// deform_displaced (count 0: deform), calling `after_block` with the index of each block
    /// of SweepKernel::kVertexBlock vertices as soon as its positions and J d are written, by
    /// the thread that wrote them (sd_deform_frame checks and composes each block while it
    /// is in that core's cache).
    void deform_in_blocks(const float* pose, int32_t count, const int32_t* moved, const float* displacements,
                          float* out, float* turned, const std::function<void(int32_t block)>& after_block);

    const Rig& rig() const { return rig_; }
    const Binding& binding() const { return binding_; }
    int vertex_count() const { return binding_.vertex_count(); }

    // Figures of the last frame, per sweep.
    std::vector<double> volume_before, volume_after;
    std::vector<int> volume_iterations;
    std::vector<double> fill_levels;  ///< per filled trunk, the level its skin was raised to

private:
    void prepare_sweeps(const SkeletonPose& pose);
    void deform_with(const float* pose, float* out, const SweepKernel::LocalMaps& maps);

    Rig rig_;
    Binding binding_;
    std::vector<int> span_base_;  // first span of each sweep
    SweepKernel kernel_;
    bool volume_enabled_ = true;
    double volume_strength_ = 1.0;
    std::vector<double> volume_offsets_;
    std::vector<JointVolumeTable> joint_volumes_;
    TrunkFill trunk_fill_;
    std::unique_ptr<Deformer> level_source_;  // fill_trunk_as: the source's trunk skin, whose fill sets the level
    std::vector<float> level_scratch_;        // its positions
    std::vector<double> trunk_need_;          // per sweep, of the last frame: the volume its fill puts back

    std::vector<std::vector<dquat>> rest_key_rotations_;  // per sweep, uncorrected rest keys
    std::vector<std::vector<dquat>> key_rotations_;       // per sweep, of the last frame
    std::vector<std::array<float, 4>> rest_inverse_;      // per sweep influence: Q_rest(u)^-1
    mutable std::recursive_mutex mutex_;
    // Kept from frame to frame (guarded by mutex_): the posed skeleton, the half-spans'
    // coefficients (sized once, in the constructor) and the bones' affine maps. A frame still
    // allocates: bone_affines() returns a new vector, and prepare_sweeps() builds per sweep the
    // posed keys, the half-axes, the sweep's geometry and volume form, and the half-axis changes.
    SkeletonPose pose_;
    std::vector<HalfSpanKernel> half_spans_;  // 2 per span
    std::vector<Affine3x4> bones_;
    std::vector<BoneFrame> bone_frames_;  // per bone, bones_ as dual quaternions
    SweepKernel::LocalMaps maps_;         // what deform() gives besides positions
};

}  // namespace sd
