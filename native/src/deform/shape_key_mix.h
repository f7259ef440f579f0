// Relative shape keys mixed as Blender mixes them, as a displacement from the bound rest.
//
// Blender evaluates relative keys as reference + Σ value (key − its relative key). A caller
// that knows the keys knows, before the mesh is evaluated, where each vertex arrives; the
// deformer then turns that displacement with the vertex's local linear map
// (Deformer::deform_displaced), for the vertices it moves only.
#pragma once

#include <cstdint>

namespace sd {

/// One active key: its block, its relative key's block, its value.
struct ShapeKeyTerm {
    int32_t key, relative;
    float value;
};

/// d[v] = reference[v] − rest[v] + Σ_terms value (blocks[key][v] − blocks[relative][v]), with
/// the reference in block 0 (each block #V*3). Writes the vertices where d is not zero, in
/// ascending order, to `moved` (capacity #V) and their d to `moves` (capacity #V*3); returns
/// how many. Inputs are trusted (the ABI checks them).
int32_t mix_shape_keys(int32_t vertex_count, const float* rest, const float* blocks, const ShapeKeyTerm* terms,
                       int32_t term_count, int32_t* moved, float* moves);

}  // namespace sd
