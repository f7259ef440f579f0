// The per-vertex half of a frame, laid out for SIMD.
//
// Every sweep influence of every vertex evaluates w (C(u) + R(u) (x + Δa cosθ, y + Δb sinθ, z))
// with C, R, Δa, Δb polynomials of its half-span. Sorting the influences by block of
// vertices, then half-span, turns that into loops over structure-of-arrays with the
// half-span's coefficients held constant, which the compiler vectorises; the same task then
// sums each of the block's vertices' contributions and bone influences in a fixed order
// (results independent of the thread count; its slots still in its core's cache).
// A vertex with more than one influence (two sweeps, or a sweep and a bone) is blended as
// rigid frames (deform/frame_blend.h); its influences sit in batches of their own that also
// give each influence's rotation, so vertices inside one sweep pay nothing for it.
#pragma once

#include "bind/bind.h"
#include "deform/frame_blend.h"
#include "deform/linear_blend_skinning.h"
#include "deform/slot_planes.h"

#include <array>
#include <cstdint>
#include <functional>
#include <utility>
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
    /// Vertices per task of the vertices' pass: block b is [b kVertexBlock, (b + 1) kVertexBlock).
    static constexpr int kVertexBlock = 2048;

    SweepKernel() = default;
    /// @param span_base  first span of each sweep in the frame's half-span array (which holds
    ///                   2 entries per span: halves u < 0.5 and u >= 0.5)
    /// @param rest_inverse  per sweep influence (the binding's order): Q_rest(u)^-1, x y z w
    SweepKernel(const Binding& binding, const std::vector<int>& span_base,
                const std::vector<std::array<float, 4>>& rest_inverse);

    /// What run() gives besides the positions: each vertex's local linear map J (blended as
    /// its position was: Σ w R(u) R_rest(u)^-1 over its sweeps, Σ w M_b (3x3) over its bones,
    /// and for a frame-blended vertex the blended rotation with its share), written out, or
    /// applied to a displacement per vertex.
    struct LocalMaps {
        float* jacobians = nullptr;            // 3 blocks of #V*3 (block r: row r of every vertex's J)
        int32_t moved_count = 0;               // displaced vertices: M (distinct, in [0, V))
        const int32_t* moved = nullptr;        // #M their indices
        const float* displacements = nullptr;  // #M*3 their displacements d, and then
        float* turned = nullptr;               // #M*3 receives J d
        /// Called with each block's index by the task that wrote its positions (and J d),
        /// while they are in its core's cache (sd_deform_frame's check and sums).
        const std::function<void(int32_t block)>* after_block = nullptr;
    };

    /// out[v] = Σ sweep contributions + Σ_b w_b M_b rest[v] for a vertex of one influence, the
    /// rigid-frame blend of the same for a vertex of several (#V*3).
    /// @param bone_frames     per bone, M_b as a dual quaternion (frame_blend.h)
    void run(const HalfSpanKernel* half_spans, const Affine3x4* bones, const BoneFrame* bone_frames,
             const Binding& binding, float* out, const LocalMaps& maps);

private:
    struct Batch {
        int32_t half_span, begin, end;
        bool frames;  // influences of vertices blended as rigid frames
    };
    std::vector<Batch> batches_;  // ranges of one half-span, <= kBatch long
    /// Per slot (influences sorted by block of vertices, then half-span): u, w, x, y, z, cos,
    /// sin; Q_rest(u)^-1 (frame-blended slots); the slot's vertex at rest. What a frame makes of
    /// them is in the evaluating thread's scratch (run()).
    enum SlotPlane : int { kU, kW, kX, kY, kZ, kCos, kSin, kRx, kRy, kRz, kRw, kVx, kVy, kVz, kSlotPlanes };
    SlotPlanes planes_;
    std::vector<float> turns_;                             // with J only: 9 per slot, w R(u) R_rest(u)^-1
    std::vector<int32_t> slot_vertex_;                     // the slot's vertex
    std::vector<int32_t> moved_at_;                        // per vertex: its displacement, or -1
    std::vector<int32_t> moved_seen_;                      // the displaced vertices the runs below were found for
    std::vector<int32_t> batch_runs_;                      // per batch: CSR rows of moved_runs_
    std::vector<std::pair<int32_t, int32_t>> moved_runs_;  // runs of slots of displaced vertices
    std::vector<uint32_t> row_offsets_, rows_;             // vertex -> its sorted influence slots
    std::vector<int32_t> plain_vertices_;                  // vertices of one influence, or none blended
    /// A frame-blended vertex's influence: a sorted slot or a bone, with its weight.
    struct BlendEntry {
        uint32_t index;
        float weight;  ///< a bone's weight; 1 for a sweep's slot, which holds its own weight
    };
    /// A frame-blended vertex: its entries from `first`, its sweeps' slots (count[0]), then
    /// its bones (count[1]).
    struct BlendedVertex {
        int32_t vertex;
        uint32_t first;
        float share;
        uint16_t count[2];
    };
    std::vector<BlendedVertex> blended_vertices_;
    std::vector<BlendEntry> blend_entries_;
    std::vector<int32_t> block_plain_, block_blended_;  // per block of vertices: its first in each list
    std::vector<int32_t> block_batches_;                // per block of vertices: its first batch
    std::vector<int32_t> block_slots_;                  // per block of vertices: its first slot
    /// Planes (one float per frame-blended vertex each) of blend_planes_: the frames' sums and
    /// the blended position written per frame, the rest position and share constant.
    enum BlendPlane : int {
        real_x = 0,
        dual_x = 4,
        position_x = 8,
        rest_x = 11,
        share_plane = 14,
        norm2_plane = 15,
        turn_x = 16,
        kBlendPlanes = 20
    };
    std::vector<float> blend_planes_;
    std::vector<float> blend_turns_;  // with J: 9 per frame-blended vertex
    int bone_count_ = 0;
    std::vector<Float4> bone_columns_;  // per frame: each bone's 3x4 matrix as 4 columns
};

}  // namespace sd
