// The one-call automatic rig (Sect. 3.2, 3.5): chains from the skeleton, key ellipses
// fitted to the mesh's cross-sections, sweeps, and per-vertex blend weights for binding.
#pragma once

#include "fit/chains.h"
#include "fit/key_fit.h"
#include "geometry/mesh.h"
#include "fit/regions.h"
#include "rig/rig.h"

#include <cstdint>
#include <string>
#include <vector>

namespace sd::fit {

/// Everything in one space (armature space), any unit: tolerances are relative.
struct FitInput {
    int vertex_count = 0;
    const float* positions = nullptr;  ///< #V*3
    int triangle_count = 0;
    const int32_t* triangles = nullptr;   ///< #T*3
    Skeleton skeleton;                    ///< validated rest skeleton (Skeleton::from_arrays)
    std::vector<std::string> bone_names;  ///< #B or empty; hints only
    int skin_slots = 0;                   ///< 0: no skin weights (regions from geometry)
    const int32_t* skin_bones = nullptr;  ///< #V*skin_slots, -1 = unused
    const float* skin_weights = nullptr;  ///< #V*skin_slots, >= 0
    /// Chains as bone index lists (body outwards); empty: find them automatically.
    std::vector<std::vector<int>> chains;
};

struct FitOptions {
    KeyOptions keys;
    RegionOptions regions;
};

struct FitResult {
    Rig rig;                ///< the skeleton and one sweep per chain that could be fitted
    RegionWeights weights;  ///< for bind_vertices
    ChainSet chains;
    std::vector<int> chain_sweep;  ///< #chains: sweep index, -1 when the chain got none
    std::vector<ChainFit> fits;    ///< #chains
    MeshStats mesh;
    std::vector<std::string> warnings;
    std::string report;  ///< JSON (see sd_fit_result_report)
};

/// Bone names from C strings: `names` may be NULL (no names) and its entries NULL (empty);
/// at most 1024 bytes of each are read.
std::vector<std::string> names_from_c(int count, const char* const* names);

/// Chains from the C ABI's compressed rows: chain c is bones[offsets[c] .. offsets[c+1]).
/// chain_count 0 gives none (automatic chains). @throws InvalidInput on bad offsets.
std::vector<std::vector<int>> chains_from_offsets(int chain_count, const int32_t* offsets, const int32_t* bones);

/// Fits a sweep rig to a rigged character.
/// @throws InvalidInput with a message naming what is wrong and where (bad arrays, a
/// skeleton in another scale than the mesh, no humanoid structure, no chain fitted).
FitResult fit_rig(const FitInput& input, const FitOptions& options = {});

}  // namespace sd::fit
