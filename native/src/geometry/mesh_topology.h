// The skin's connectivity, fixed for the life of an anatomy object: which triangles touch a
// vertex, a vertex's one-ring neighbours with rest edge lengths (for geodesic falloffs), and
// the signed volume of triangles.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

namespace sd::anatomy {

struct MeshTopology {
    int vertex_count = 0;
    std::vector<int32_t> triangles;                 ///< #T*3 vertex indices
    std::vector<uint32_t> vertex_triangle_offsets;  ///< #V+1, CSR rows of vertex_triangles
    std::vector<int32_t> vertex_triangles;
    std::vector<uint32_t> neighbour_offsets;  ///< #V+1, CSR rows of neighbours
    std::vector<int32_t> neighbours;
    std::vector<float> edge_lengths;  ///< rest length of each neighbours[] entry

    int triangle_count() const { return static_cast<int>(triangles.size() / 3); }
    const int32_t* triangle(int t) const { return &triangles[3 * static_cast<size_t>(t)]; }

    /// @param triangles  #T*3 indices in [0, V); a triangle repeating a vertex is kept (it is
    ///                   degenerate, which the exact tests handle) but adds no edge twice.
    /// @throws InvalidInput on an index out of range.
    static MeshTopology build(int vertex_count, const int32_t* triangles, int triangle_count,
                              const float* rest_positions);
};

/// True when triangles a and b (each 3 vertex indices) share a vertex.
inline bool share_vertex(const int32_t* a, const int32_t* b) {
    for (int i = 0; i < 3; ++i)
        if (a[i] == b[0] || a[i] == b[1] || a[i] == b[2]) return true;
    return false;
}

/// Signed volume of the tetrahedron (o, p0, p1, p2): (p0-o).((p1-o)x(p2-o)) / 6.
double signed_volume(const float* p0, const float* p1, const float* p2, const double* o);

}  // namespace sd::anatomy
