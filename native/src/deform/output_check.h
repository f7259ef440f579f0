// The bound on a frame's output (issue 15): a sweep moves a vertex with its limb, so its
// distance to the bones it is skinned to changes at a joint (the skin folds, bulges, keeps its
// volume) but not by much. A frame with a vertex farther from its posed bones than a multiple
// of its rest distance (shards a metre off the body, a non-finite result) is not shown: the
// caller shows the linear blend skinning of the same pose instead, which this class also
// computes. Per vertex: the nearer of its two heaviest skin bones, as segments head -> tail
// (a bone lies along its matrix's Y axis, as in Blender); rest distances below a floor (a
// share of the rest body's bounding-box diagonal) count as that floor.
//
// Read-only after construction: several threads may check frames with one object at once.
#pragma once

#include "math/math_types.h"

#include <cstdint>
#include <memory>
#include <vector>

namespace sd {

class OutputCheck {
public:
    /// What one frame's check found.
    struct Verdict {
        int32_t beyond = 0;         ///< vertices whose ratio is above the limit (or not finite)
        double worst_ratio = 0.0;   ///< the largest ratio among them (inf for a non-finite vertex), 0: none
        int32_t worst_vertex = -1;  ///< its vertex (the lowest index among equals), -1: none
        int32_t worst_bone = -1;    ///< that vertex's heaviest skin bone, -1: none
    };

    /// rest_positions #V*3 and rest_pose #B*16 (column-major) in one space; bone_lengths #B
    /// (> 0); skin_bones / skin_weights #V*S (-1: unused slot; weights >= 0); floor_share in
    /// [0, 1]. @throws InvalidInput for counts, indices or numbers out of range.
    OutputCheck(int32_t vertex_count, const float* rest_positions, int32_t bone_count, const float* rest_pose,
                const float* bone_lengths, int32_t skin_slots, const int32_t* skin_bones, const float* skin_weights,
                double floor_share);

    /// Checks the deformed `positions` (#V*3, may hold non-finite values: those vertices are
    /// beyond) of `pose` (#B*16, finite) against ratio_limit. `ratios` (#V, may be NULL)
    /// receives every vertex's ratio (0 for a vertex without skin weights). Parallel; the
    /// result does not depend on the number of threads. A chunk of vertices all within the
    /// limit of their bone nearer at rest (by a margin) is within without a look at the other
    /// bone (the nearer of the two can only be nearer): one float squared distance per vertex,
    /// vectorised, for most frames; other chunks get the exact test (double, both bones).
    Verdict check(const float* pose, const float* positions, double ratio_limit, float* ratios) const;

    /// One frame's check in pieces, for a caller that checks each block of vertices as it
    /// writes them (sd_deform_frame): made once per frame, then range() on blocks of
    /// `block_size` vertices from any threads, each block once; verdict() combines the
    /// blocks in order (the result does not depend on the threads or their order).
    /// check() is this with blocks of its own.
    class Frame {
    public:
        /// As check()'s arguments; @throws InvalidInput as check() does.
        Frame(const OutputCheck& check, const float* pose, double ratio_limit, float* ratios, int32_t block_size);
        ~Frame();
        /// Checks block `block`: vertices [block x block_size, min(V, (block + 1) x block_size)).
        void range(const float* positions, int32_t block);
        Verdict verdict() const;

    private:
        struct Posed;
        const OutputCheck& check_;
        std::unique_ptr<const Posed> posed_;
        float* ratios_;
        int32_t block_size_;
        std::vector<Verdict> found_;  // per block
    };

    /// The linear blend skinning of the rest positions by `pose` (#B*16) into `out` (#V*3):
    /// the fallback shown for a frame beyond the bound. A vertex without skin weights stays
    /// at rest.
    void linear_blend(const float* pose, float* out) const;

    int32_t vertex_count() const { return static_cast<int32_t>(rest_.size()); }
    int32_t bone_count() const { return static_cast<int32_t>(lengths_.size()); }
    /// Each vertex's rest distance to its nearer bone, floored (tests, reports).
    const std::vector<double>& rest_distances() const { return rest_distance_; }

private:
    struct Slot {
        int32_t bone;
        double weight;  // normalised over the vertex's slots
    };
    /// A skinned vertex's two heaviest skin bones, the one nearer at rest first, and its
    /// squared rest distance (floored).
    struct Bones {
        int32_t near = -1, far = -1;  // -1: no skin weights
        double rest2 = 0.0;
    };
    int32_t slots_ = 0;
    std::vector<dvec3> rest_;
    std::vector<double> lengths_;
    std::vector<dmat4> inverse_rest_;
    std::vector<Bones> bones_;
    std::vector<int32_t> heaviest_;    // -1: no skin weights
    std::vector<int32_t> near_;        // the float filter's: the bone nearer at rest (0: no skin weights)
    std::vector<float> filter_rest2_;  // and the squared rest distance, less a margin (inf: no skin weights)
    std::vector<double> rest_distance_;
    std::vector<Slot> skin_;  // V * slots_
};

}  // namespace sd
