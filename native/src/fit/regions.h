// Regions and blend weights (Sect. 3.5): which sweeps (and, for hands, feet and head,
// which bones) move each vertex, with weights that change smoothly where two sweeps meet
// (shoulders, hips, neck).
#pragma once

#include "fit/chains.h"
#include "geometry/mesh.h"
#include "rig/rig.h"

#include <cstdint>
#include <string>
#include <vector>

namespace sd::fit {

/// Per vertex and chain: how much of the vertex belongs to the chain, its rigid parts
/// included (a hand counts for its arm). The key fitting keeps the part of a cut whose
/// share is >= 0.5, so an arm's shoulder key ignores the torso it runs into.
struct PartShares {
    int chains = 0;
    std::vector<float> share;  ///< #V*chains, each row sums to <= 1
    float at(int v, int c) const { return share[static_cast<size_t>(v) * chains + c]; }
};

/// Shares from skin weights: the summed weights of the chain's bones and rigid parts.
/// @param bones, weights  #V*slots, bone -1 = unused slot
PartShares shares_from_skin(int vertex_count, int slots, const int32_t* bones, const float* weights,
                            const BoneOwners& owners, int chain_count);

/// Shares from geometry (no skin weights): each vertex goes to its nearest bone segment's
/// chain, then a few smoothing passes soften the borders.
PartShares shares_from_nearest_bones(const FitMesh& mesh, const Skeleton& skeleton, const BoneOwners& owners,
                                     int chain_count);

/// Shares from a first rig (no skin weights): each vertex goes to the sweep it lies most
/// inside of (in ellipse radii), or to its nearest bone's chain when that bone is rigid;
/// smoothed like the above. Used to refit the keys after a first pass.
PartShares shares_from_sweeps(const FitMesh& mesh, const Rig& rig, const BoneOwners& owners,
                              const std::vector<int>& chain_sweep);

/// `iterations` Jacobi passes of one-ring Laplacian smoothing with step `lambda` on the
/// rows of `values` (#V*width) over the vertices with active[v] != 0 (others stay and are
/// not used as neighbours). Parallel; the result does not depend on the thread count.
/// `reach` > 0 bounds how far the passes carry a value as a length (the mesh's unit), not a
/// number of rings: a vertex whose one-ring edges are longer on average than `reach` takes
/// the step lambda (reach / edge)^2, so the spread (about sqrt(passes × step) edges) stays
/// near what it is on a mesh with edges of that length.
void smooth_rows(const FitMesh& mesh, int width, std::vector<float>& values, const std::vector<char>& active,
                 int iterations, float lambda, double reach = 0.0);

/// The reach of the binding weights' smoothing: this share of the rest mesh's bounding-box
/// diagonal (2.7 cm on a 1.8 m body). Six passes over one ring spread a sweep's share about
/// 1.7 edges: 0.5 cm on the 53.5K MakeHuman, 1 cm on its 13K version, and on CesiumMan, whose
/// thigh has a ring of vertices every 5-8 cm, 10 cm and more: the torso's 4 % of skin weight
/// half way down its thigh became 14 %, and hip_flex_90 pulled that skin 2.9 cm off the
/// thigh (r_max 1.50 against Preserve Volume's 1.39).
constexpr double kSmoothingReachOfDiagonal = 0.0125;

/// The weights to pass to bind_vertices: #V*sweep_slots sweep ids/weights and
/// #V*bone_slots bone ids/weights (-1 = unused), plus what they amount to.
struct RegionWeights {
    int sweep_slots = 0, bone_slots = 0;
    std::vector<int32_t> sweep_ids, bone_ids;
    std::vector<float> sweep_weights, bone_weights;
    std::string source;                  ///< "skin weights" or "geometry"
    int vertices_bound = 0;              ///< with a positive total weight
    int vertices_on_sweeps = 0;          ///< with any sweep weight
    int vertices_rigid_only = 0;         ///< bone-driven only
    int vertices_blended = 0;            ///< on two or more sweeps
    int vertices_from_nearest_bone = 0;  ///< had no skin weight: nearest bone instead
    int vertices_beside_spine = 0;       ///< part of their trunk weight given to the spine's bones (spine_skin.h)
};

/// Recounts vertices_bound, _on_sweeps, _rigid_only and _blended from the weights.
void count_region(RegionWeights& r, int vertex_count);

struct RegionOptions {
    int smoothing_iterations = 6;
    float smoothing_step = 0.5f;
    int sweep_slots = 3;
};

/// Seeds from skin weights: a vertex's weight on chain c's sweep is the summed weight of
/// c's swept link bones; its weights on rigid bones (hand, fingers, feet, head, the bones of
/// any chain without a sweep, and inner links such as a clavicle, whose skin on the chest
/// and back a sweep starting at the shoulder would swing with the arm) stay the skin's own.
/// The split among sweeps is then smoothed over the one-ring, so shoulder, hip and neck
/// transitions change gradually; the split between sweeps and rigid parts is the skin's.
/// Vertices without skin weight take their nearest bone.
/// @param chain_sweep  #chains: sweep index in the rig, -1 if the chain has no sweep
RegionWeights weights_from_skin(const FitMesh& mesh, const Skeleton& skeleton, const BoneOwners& owners,
                                const std::vector<int>& chain_sweep, int slots, const int32_t* bones,
                                const float* weights, const RegionOptions& options);

/// Without skin weights: each vertex goes to its nearest bone if that is a rigid part,
/// else to the sweep it lies most inside of (in ellipse radii); where a limb or the neck
/// meets its parent chain the weight moves from one sweep to the other with the relative
/// distance between two bounding planes parallel to the limb's first key ellipse (the
/// paper's rule), and likewise from a chain to its rigid end part across the end key;
/// then the one-ring smoothing.
RegionWeights weights_from_geometry(const FitMesh& mesh, const Rig& rig, const ChainSet& chains,
                                    const BoneOwners& owners, const std::vector<int>& chain_sweep,
                                    const RegionOptions& options);

}  // namespace sd::fit
