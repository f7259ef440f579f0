#include "geometry/mesh.h"

#include "geometry/mesh_halfedge.h"

#include <OpenMesh/Core/System/omstream.hh>

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <tuple>

namespace sd::fit {

namespace {

int find_root(std::vector<int32_t>& parent, int x) {
    while (parent[x] != x) {
        parent[x] = parent[parent[x]];
        x = parent[x];
    }
    return x;
}

/// Silences OpenMesh's "complex edge" messages while faces are added: refused faces are
/// handled and counted here, and a library must not write to the host's stderr.
class QuietOpenMesh {
public:
    QuietOpenMesh() : was_enabled_(omerr().is_enabled()) { omerr().disable(); }
    ~QuietOpenMesh() {
        if (was_enabled_) omerr().enable();
    }
    QuietOpenMesh(const QuietOpenMesh&) = delete;
    QuietOpenMesh& operator=(const QuietOpenMesh&) = delete;

private:
    bool was_enabled_;
};

}  // namespace

FitMesh::~FitMesh() = default;

FitMesh::FitMesh(int V, const float* positions, int T, const int32_t* triangles)
    : halfedge_(std::make_unique<HalfEdge>()) {
    if (V < 3 || V > 50'000'000) throw InvalidInput("vertex count must be in 3..5e7, got " + std::to_string(V));
    if (T < 1 || T > 100'000'000) throw InvalidInput("triangle count must be in 1..1e8, got " + std::to_string(T));
    if (!positions || !triangles) throw InvalidInput("mesh positions or triangles is NULL");
    positions_.resize(V);
    lo_ = dvec3(std::numeric_limits<double>::infinity());
    hi_ = -lo_;
    for (int v = 0; v < V; ++v) {
        const dvec3 p(positions[3 * v], positions[3 * v + 1], positions[3 * v + 2]);
        if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z) || glm::length(p) > 1e12)
            throw InvalidInput("mesh vertex " + std::to_string(v) + " has a non-finite or enormous coordinate");
        positions_[v] = p;
        lo_ = glm::min(lo_, p);
        hi_ = glm::max(hi_, p);
    }
    if (!(diagonal() > 0.0)) throw InvalidInput("the mesh has zero extent (all vertices coincide)");

    stats_.vertices = V;
    stats_.triangles = T;
    triangles_.reserve(static_cast<size_t>(T) * 3);
    for (int t = 0; t < T; ++t) {
        const int32_t* f = triangles + 3 * t;
        for (int i = 0; i < 3; ++i)
            if (f[i] < 0 || f[i] >= V)
                throw InvalidInput("triangle " + std::to_string(t) + " refers to vertex " + std::to_string(f[i]) +
                                   ", out of range 0.." + std::to_string(V - 1));
        if (f[0] == f[1] || f[1] == f[2] || f[0] == f[2]) {
            ++stats_.degenerate_triangles;
            continue;
        }
        triangles_.insert(triangles_.end(), f, f + 3);
    }
    const int kept = static_cast<int>(triangles_.size() / 3);
    if (kept == 0) throw InvalidInput("every triangle of the mesh is degenerate (repeated vertex index)");

    // One-ring adjacency (compressed rows), and loose parts by union-find.
    std::vector<int32_t> count(V + 1, 0), parent(V);
    std::iota(parent.begin(), parent.end(), 0);
    for (int t = 0; t < kept; ++t)
        for (int i = 0; i < 3; ++i) {
            count[triangles_[3 * t + i] + 1] += 2;
            const int a = find_root(parent, triangles_[3 * t + i]);
            const int b = find_root(parent, triangles_[3 * t + (i + 1) % 3]);
            if (a != b) parent[a] = b;
        }
    std::partial_sum(count.begin(), count.end(), count.begin());
    std::vector<int32_t> raw(count.back()), fill(count.begin(), count.end() - 1);
    for (int t = 0; t < kept; ++t)
        for (int i = 0; i < 3; ++i) {
            const int v = triangles_[3 * t + i];
            raw[fill[v]++] = triangles_[3 * t + (i + 1) % 3];
            raw[fill[v]++] = triangles_[3 * t + (i + 2) % 3];
        }
    ring_offsets_.assign(V + 1, 0);
    ring_.reserve(raw.size() / 2 + 16);
    for (int v = 0; v < V; ++v) {
        auto first = raw.begin() + count[v], last = raw.begin() + count[v + 1];
        std::sort(first, last);
        last = std::unique(first, last);
        ring_.insert(ring_.end(), first, last);
        ring_offsets_[v + 1] = static_cast<int32_t>(ring_.size());
        if (first == last)
            ++stats_.unused_vertices;
        else if (find_root(parent, v) == v)
            ++stats_.components;
    }

    weld_rings();

    // The half-edge structure for plane cuts.
    OpenMeshTri& m = halfedge_->mesh;
    std::vector<int32_t>& input = halfedge_->input_vertex;
    m.reserve(static_cast<size_t>(V), static_cast<size_t>(kept) * 3, static_cast<size_t>(kept));
    input.resize(V);
    for (int v = 0; v < V; ++v) {
        m.new_vertex();
        input[v] = v;
    }
    {
        QuietOpenMesh quiet;
        for (int t = 0; t < kept; ++t) {
            const int32_t* f = &triangles_[3 * t];
            OpenMesh::VertexHandle vh[3] = {OpenMesh::VertexHandle(f[0]), OpenMesh::VertexHandle(f[1]),
                                            OpenMesh::VertexHandle(f[2])};
            if (m.add_face(vh[0], vh[1], vh[2]).is_valid()) continue;
            // A complex edge or vertex: the face goes on copies of its vertices, so the cut
            // walk sees a border there and closes the loop over the small gap.
            ++stats_.nonmanifold_faces;
            for (int i = 0; i < 3; ++i) {
                vh[i] = m.new_vertex();
                input.push_back(f[i]);
            }
            m.add_face(vh[0], vh[1], vh[2]);
        }
    }
    for (auto e : m.edges())
        if (e.is_boundary()) ++stats_.boundary_edges;
}

void FitMesh::weld_rings() {
    // Vertices at the same position (a mesh split at UV seams, as glTF files are) are one
    // point of the skin: each gets the union of their rings, in representatives, so weights
    // smoothed over the rings stay equal across a seam (on CesiumMan they differed by up to
    // 0.31, which opened a 1.9 cm crack along the belt line at 90 degrees of hip flexion).
    const int V = vertex_count();
    std::vector<int32_t> order(V), rep(V);
    std::iota(order.begin(), order.end(), 0);
    const auto key = [&](int v) { return std::tie(positions_[v].x, positions_[v].y, positions_[v].z); };
    std::sort(order.begin(), order.end(), [&](int a, int b) { return key(a) < key(b); });
    bool any = false;
    for (int i = 0; i < V; ++i) {
        const int v = order[i];
        const bool twin = i > 0 && positions_[order[i - 1]] == positions_[v];
        rep[v] = twin ? rep[order[i - 1]] : v;
        any = any || twin;
    }
    if (!any) return;
    std::vector<std::vector<int32_t>> rings(V);
    for (int v = 0; v < V; ++v)
        for (int i = ring_offsets_[v]; i < ring_offsets_[v + 1]; ++i)
            if (rep[ring_[i]] != rep[v]) rings[rep[v]].push_back(rep[ring_[i]]);
    for (auto& r : rings) {
        std::sort(r.begin(), r.end());
        r.erase(std::unique(r.begin(), r.end()), r.end());
    }
    std::vector<int32_t> offsets(V + 1, 0), welded;
    welded.reserve(ring_.size());
    for (int v = 0; v < V; ++v) {
        const auto& r = rings[rep[v]];
        welded.insert(welded.end(), r.begin(), r.end());
        offsets[v + 1] = static_cast<int32_t>(welded.size());
    }
    ring_offsets_ = std::move(offsets);
    ring_ = std::move(welded);
}

}  // namespace sd::fit
