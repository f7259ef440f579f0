// The character's rest mesh as the fitting sees it: positions in double, validated
// triangles, one-ring adjacency (for smoothing region weights) and a half-edge structure
// (OpenMesh) for walking plane cuts, plus what was wrong with the mesh, for the report.
#pragma once

#include "math/math_types.h"

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

namespace sd::fit {

/// What the mesh looked like; meshes in the wild have loose parts, holes and non-manifold
/// spots, which the fitting survives but reports.
struct MeshStats {
    int vertices = 0, triangles = 0;
    int degenerate_triangles = 0;  ///< repeated vertex index: skipped
    int nonmanifold_faces = 0;     ///< refused by the half-edge structure: added on copies of their vertices
    int boundary_edges = 0;        ///< edges with one face (holes, open borders, UV-seam splits)
    int components = 0;            ///< loose parts (body, eyes, teeth, clothes, ...)
    int unused_vertices = 0;       ///< in no triangle
};

class FitMesh {
public:
    /// @param positions  #V*3 rest positions (armature space, any unit)
    /// @param triangles  #T*3 vertex indices, T >= 1
    /// @throws InvalidInput naming the first bad vertex or triangle.
    FitMesh(int vertex_count, const float* positions, int triangle_count, const int32_t* triangles);
    ~FitMesh();
    FitMesh(const FitMesh&) = delete;
    FitMesh& operator=(const FitMesh&) = delete;

    int vertex_count() const { return static_cast<int>(positions_.size()); }
    const std::vector<dvec3>& positions() const { return positions_; }
    const std::vector<int32_t>& triangles() const { return triangles_; }  ///< kept ones, #T'*3
    dvec3 bbox_min() const { return lo_; }
    dvec3 bbox_max() const { return hi_; }
    /// Length of the bounding box diagonal: the unit of every relative tolerance.
    double diagonal() const { return glm::length(hi_ - lo_); }
    const MeshStats& stats() const { return stats_; }

    /// One-ring neighbours of vertex v: ring_[ring_offsets_[v] .. ring_offsets_[v+1]), with
    /// vertices at the same position welded (one ring each, in representatives).
    const std::vector<int32_t>& ring_offsets() const { return ring_offsets_; }
    const std::vector<int32_t>& ring() const { return ring_; }

    struct HalfEdge;  ///< the OpenMesh structure (geometry/mesh_halfedge.h)
    const HalfEdge& halfedge() const { return *halfedge_; }

private:
    std::vector<dvec3> positions_;
    std::vector<int32_t> triangles_;
    dvec3 lo_{0.0}, hi_{0.0};
    MeshStats stats_;
    std::vector<int32_t> ring_offsets_, ring_;
    void weld_rings();
    std::unique_ptr<HalfEdge> halfedge_;
};

}  // namespace sd::fit
