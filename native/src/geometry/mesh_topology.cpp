#include "geometry/mesh_topology.h"

#include "math/math_types.h"

#include <algorithm>
#include <cmath>
#include <string>

namespace sd::anatomy {

MeshTopology MeshTopology::build(int V, const int32_t* tris, int T, const float* rest) {
    if (V < 3 || T < 1 || !tris || !rest) throw InvalidInput("a mesh needs >= 3 vertices and >= 1 triangle");
    MeshTopology m;
    m.vertex_count = V;
    m.triangles.assign(tris, tris + 3 * static_cast<size_t>(T));
    for (int t = 0; t < T; ++t)
        for (int k = 0; k < 3; ++k) {
            const int32_t v = tris[3 * t + k];
            if (v < 0 || v >= V)
                throw InvalidInput("triangle " + std::to_string(t) + " has vertex index " + std::to_string(v) +
                                   " outside 0.." + std::to_string(V - 1));
        }
    m.vertex_triangle_offsets.assign(V + 1, 0);
    for (int32_t v : m.triangles) ++m.vertex_triangle_offsets[v + 1];
    for (int v = 0; v < V; ++v) m.vertex_triangle_offsets[v + 1] += m.vertex_triangle_offsets[v];
    m.vertex_triangles.resize(m.triangles.size());
    std::vector<uint32_t> fill(m.vertex_triangle_offsets.begin(), m.vertex_triangle_offsets.end() - 1);
    for (int t = 0; t < T; ++t)
        for (int k = 0; k < 3; ++k) m.vertex_triangles[fill[tris[3 * t + k]]++] = t;

    // One-ring: the other vertices of the incident triangles, sorted and unique.
    m.neighbour_offsets.assign(V + 1, 0);
    std::vector<int32_t> ring;
    for (int v = 0; v < V; ++v) {
        ring.clear();
        for (uint32_t i = m.vertex_triangle_offsets[v]; i < m.vertex_triangle_offsets[v + 1]; ++i) {
            const int32_t* t = m.triangle(m.vertex_triangles[i]);
            for (int k = 0; k < 3; ++k)
                if (t[k] != v) ring.push_back(t[k]);
        }
        std::sort(ring.begin(), ring.end());
        ring.erase(std::unique(ring.begin(), ring.end()), ring.end());
        for (int32_t n : ring) {
            m.neighbours.push_back(n);
            const float* a = rest + 3 * static_cast<size_t>(v);
            const float* b = rest + 3 * static_cast<size_t>(n);
            m.edge_lengths.push_back(std::sqrt((a[0] - b[0]) * (a[0] - b[0]) + (a[1] - b[1]) * (a[1] - b[1]) +
                                               (a[2] - b[2]) * (a[2] - b[2])));
        }
        m.neighbour_offsets[v + 1] = static_cast<uint32_t>(m.neighbours.size());
    }
    return m;
}

double signed_volume(const float* p0, const float* p1, const float* p2, const double* o) {
    const double a[3] = {p0[0] - o[0], p0[1] - o[1], p0[2] - o[2]};
    const double b[3] = {p1[0] - o[0], p1[1] - o[1], p1[2] - o[2]};
    const double c[3] = {p2[0] - o[0], p2[1] - o[1], p2[2] - o[2]};
    return (a[0] * (b[1] * c[2] - b[2] * c[1]) + a[1] * (b[2] * c[0] - b[0] * c[2]) +
            a[2] * (b[0] * c[1] - b[1] * c[0])) /
           6.0;
}

}  // namespace sd::anatomy
