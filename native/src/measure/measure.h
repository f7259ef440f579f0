// Measurements for reports and tests: the figures the demo puts next to Blender's own
// Armature modifier (volume, intersecting triangle pairs, cross-section areas). They work
// on any triangle mesh, deformed by anything.
#pragma once

#include "math/math_types.h"

#include <cstdint>
#include <vector>

namespace sd::measure {

/// Volume enclosed by a closed, consistently oriented triangle mesh (divergence theorem),
/// units^3; positive for outward-facing triangles.
/// @param positions #V*3  @param triangles #T*3, indices validated by the caller
double closed_mesh_volume(int vertex_count, const float* positions, int triangle_count, const int32_t* triangles);

/// Number of pairs of triangles of `subset` (indices into triangles; empty = all) that
/// intersect and share no vertex, by the exact triangle–triangle test of the anatomy module.
int64_t intersecting_pairs(int vertex_count, const float* positions, int triangle_count, const int32_t* triangles,
                           const std::vector<int32_t>& subset);

/// Areas of the cross-sections of the mesh by the planes (point_i, normal_i): the area of
/// the cut loop that surrounds point_i (or the nearest loop within `reach`), 0 when none.
std::vector<double> cross_section_areas(int vertex_count, const float* positions, int triangle_count,
                                        const int32_t* triangles, const std::vector<dvec3>& points,
                                        const std::vector<dvec3>& normals, double reach);

}  // namespace sd::measure
