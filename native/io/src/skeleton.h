// Private skeleton and skin-weight helpers shared by the glTF loader and the refinement.
#pragma once

#include <cstdint>

#include "sweepdeform_io/character.h"

namespace sd::io::detail {

/// Fills c.bone_heads (translations of c.bone_rest) and c.bone_tails by the rules documented
/// in gltf_loader.h. Needs c.bone_rest and c.bone_parents (parents first).
/// mesh_size: the rest mesh's bounding-box diagonal, scale for the fallback lengths.
void compute_bone_heads_tails(Character& c, double mesh_size);

/// Index of the bone whose head-tail segment is nearest to point p[3] (needs heads/tails).
int32_t nearest_bone(const Character& c, const float* p);

/// Merges repeated joints, keeps the 4 largest positive influences of a vertex, sorted by decreasing weight and
/// normalised to sum 1; unused slots get index 0 and weight 0. n = number of inputs.
/// Returns false (and writes nothing) when no weight is positive.
bool top4_normalised(const int32_t* joints, const float* weights, int n, int32_t* out_joints, float* out_weights);

}  // namespace sd::io::detail
