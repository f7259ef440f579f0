// Binding a rest mesh to the sweeps of a rig (Sect. 3.3–3.5).
//
// For every (vertex V, sweep) pair with a positive weight:
//  - t_V from the sampled planes P(t_j): between the two consecutive planes that enclose V,
//    t_V = (d_{j+1} t_j + d_j t_{j+1}) / (d_j + d_{j+1}) with d the distances to the planes;
//  - the local coordinates R(t_V)^T (V - C(t_V)) = (a_V cos θ_V, b_V sin θ_V, c_V).
// Unlike the paper we keep the out-of-plane part c_V, so the rest pose reproduces the mesh
// to float rounding. Vertices on no sweep are bound to bones (linear blend skinning).
#pragma once

#include "rig/rig.h"

#include <cstdint>
#include <vector>

namespace sd {

struct SweepInfluence {
    int32_t sweep = 0;
    int32_t span = 0;  ///< between keys span and span+1
    float u = 0;       ///< in [0, 1] along the span
    float weight = 0;
    float local[3] = {0, 0, 0};  ///< R^T (V - C) at rest: a_V cos θ, b_V sin θ, c_V
    float cos_theta = 1, sin_theta = 0;
};

struct BoneInfluence {
    int32_t bone = 0;
    float weight = 0;
};

/// Per-vertex influences in compressed rows: vertex v owns
/// sweep_influences[sweep_offsets[v] .. sweep_offsets[v+1]) and likewise for bones.
struct Binding {
    std::vector<float> rest_positions;                  ///< #V*3
    std::vector<uint32_t> sweep_offsets, bone_offsets;  ///< #V+1 each
    std::vector<SweepInfluence> sweep_influences;
    std::vector<BoneInfluence> bone_influences;
    uint64_t rig_fingerprint = 0;  ///< of the rig it was made with

    int vertex_count() const { return static_cast<int>(rest_positions.size() / 3); }

    /// @throws CorruptData unless the rows are well formed and every number finite.
    void check_structure() const;
    /// @throws InvalidInput unless every sweep, span and bone index exists in `rig`.
    void check_against(const Rig& rig) const;
};

/// Number of planes sampled per span when binding.
constexpr int kBindSamplesPerSpan = 16;

/// A plane P(t_j) of a sweep at rest, sampled for binding.
struct PlaneSample {
    int span;
    double u;
    dvec3 center, normal;
};

/// kBindSamplesPerSpan planes per span plus the end plane, in order along the sweep.
std::vector<PlaneSample> sample_planes(const Sweep& sweep);

/// Binds one vertex to one sweep at rest: its (span, u) and local coordinates.
/// @param planes  sample_planes(sweep)
SweepInfluence bind_to_sweep(const Sweep& sweep, int sweep_index, const std::vector<PlaneSample>& planes,
                             const dvec3& v);

/// Binds all vertices. Weight arrays are #V*slots with index -1 for unused slots. Then
/// hand_over_at_sweep_ends, unless the weights come from a binding that had it already
/// (`weights_handed_over`: the displacement map's points take the mesh's final weights).
/// @throws InvalidInput (message names the vertex) on bad input.
Binding bind_vertices(const Rig& rig, int vertex_count, const float* positions, int sweep_slots,
                      const int32_t* sweep_ids, const float* sweep_weights, int bone_slots, const int32_t* bone_ids,
                      const float* bone_weights, bool weights_handed_over = false);

/// How far (in the end ellipse's larger half-axis) the hand-over below reaches from a plane.
constexpr double kHandOverReach = 4.0;

/// Where a sweep ends at a joint (an arm's shoulder and wrist, a leg's hip and ankle, the
/// neck's base and head), the skin's weight passes smoothly between the sweep and the end
/// key's bone across the end plane (see bind.cpp); bind_vertices calls it last.
void hand_over_at_sweep_ends(const Rig& rig, const float* positions, Binding& binding);

/// The rows of `vertices` (ascending, distinct indices of `binding`'s) as a binding of their own:
/// its vertex i is vertices[i].
Binding binding_of_vertices(const Binding& binding, const std::vector<int32_t>& vertices);

}  // namespace sd
