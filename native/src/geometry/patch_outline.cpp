#include "geometry/patch_outline.h"

#include "geometry/bvh.h"
#include "geometry/disjoint_sets.h"
#include "geometry/exact_predicates.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace sd::anatomy {

namespace {

// An outline edge is kept as its key with the top bit telling its direction in its triangle
// (set: from the second vertex to the first), so the outline is a directed loop.
constexpr uint64_t kReversed = uint64_t(1) << 63;
uint64_t key_of(uint64_t edge) { return edge & ~kReversed; }
int32_t first_vertex(uint64_t edge) { return static_cast<int32_t>((edge >> 32) & 0x7fffffffu); }
int32_t second_vertex(uint64_t edge) { return static_cast<int32_t>(edge & 0xffffffffu); }
int32_t from_vertex(uint64_t edge) { return edge & kReversed ? second_vertex(edge) : first_vertex(edge); }
int32_t to_vertex(uint64_t edge) { return edge & kReversed ? first_vertex(edge) : second_vertex(edge); }
uint64_t directed_edge(int32_t from, int32_t to) {
    return PatchOutlines::edge_key(from, to) | (from > to ? kReversed : 0);
}

/// Per slot: false when its triangle is degenerate, has an edge that three or more triangles
/// of the set use, or has a vertex whose triangles in the set form more than one fan. Every
/// node made only of the others is a surface with boundary, which the outline's length and
/// the Euler characteristic then tell a disk.
std::vector<uint8_t> regular_slots(const TriangleBvh& bvh) {
    const int n = bvh.size();
    std::vector<uint8_t> good(n, 1);
    std::vector<std::pair<uint64_t, int32_t>> edges;
    std::vector<std::pair<int32_t, int32_t>> at_vertex;
    edges.reserve(3 * static_cast<size_t>(n));
    at_vertex.reserve(3 * static_cast<size_t>(n));
    for (int s = 0; s < n; ++s) {
        const int32_t* v = bvh.vertices(s);
        if (v[0] == v[1] || v[1] == v[2] || v[0] == v[2]) good[s] = 0;
        for (int e = 0; e < 3; ++e) {
            edges.push_back({PatchOutlines::edge_key(v[e], v[(e + 1) % 3]), s});
            at_vertex.push_back({v[e], s});
        }
    }
    std::sort(edges.begin(), edges.end());
    for (size_t i = 0; i < edges.size();) {
        size_t j = i;
        while (j < edges.size() && edges[j].first == edges[i].first) ++j;
        if (j - i > 2)
            for (size_t k = i; k < j; ++k) good[edges[k].second] = 0;
        i = j;
    }
    std::sort(at_vertex.begin(), at_vertex.end());
    for (size_t i = 0; i < at_vertex.size();) {
        size_t j = i;
        while (j < at_vertex.size() && at_vertex[j].first == at_vertex[i].first) ++j;
        // The fan about the vertex: triangles joined across the edges that meet at it.
        const int32_t vertex = at_vertex[i].first;
        DisjointSets fan(j - i);
        size_t parts = j - i;
        for (size_t a = i; a < j; ++a)
            for (size_t b = a + 1; b < j; ++b) {
                const int32_t* va = bvh.vertices(at_vertex[a].second);
                const int32_t* vb = bvh.vertices(at_vertex[b].second);
                bool shared_edge = false;
                for (int x = 0; x < 3; ++x)
                    if (va[x] != vertex && (va[x] == vb[0] || va[x] == vb[1] || va[x] == vb[2])) shared_edge = true;
                if (shared_edge && fan.unite(static_cast<int32_t>(a - i), static_cast<int32_t>(b - i))) --parts;
            }
        if (parts != 1)
            for (size_t k = i; k < j; ++k) good[at_vertex[k].second] = 0;
        i = j;
    }
    return good;
}

/// The distinct vertices of sorted edge keys, sorted, into `out`.
void outline_vertices(const uint64_t* edges, size_t count, std::vector<int32_t>& out) {
    out.clear();
    for (size_t i = 0; i < count; ++i) {
        out.push_back(first_vertex(edges[i]));
        out.push_back(second_vertex(edges[i]));
    }
    std::sort(out.begin(), out.end());
}

/// True when each vertex of the sorted endpoint list `ends` (each edge's two ends) ends
/// exactly two edges: the outline is a union of loops through distinct vertices.
bool every_vertex_on_two_edges(const std::vector<int32_t>& ends) {
    for (size_t i = 0; i < ends.size();) {
        size_t j = i;
        while (j < ends.size() && ends[j] == ends[i]) ++j;
        if (j - i != 2) return false;
        i = j;
    }
    return true;
}

size_t distinct(const std::vector<int32_t>& sorted) {
    size_t found = 0;
    for (size_t i = 0; i < sorted.size(); ++i) found += i == 0 || sorted[i] != sorted[i - 1];
    return found;
}

/// Number of values present in both sorted lists (each counted once).
size_t common(const int32_t* a, size_t na, const int32_t* b, size_t nb) {
    size_t i = 0, j = 0, found = 0;
    while (i < na && j < nb) {
        if (a[i] < b[j]) {
            ++i;
        } else if (b[j] < a[i]) {
            ++j;
        } else {
            ++found;
            const int32_t x = a[i];
            while (i < na && a[i] == x) ++i;
            while (j < nb && b[j] == x) ++j;
        }
    }
    return found;
}

/// The symmetric difference of two lists of directed edges sorted by key into `out`;
/// returns how many keys they share.
size_t symmetric_difference(const uint64_t* a, size_t na, const uint64_t* b, size_t nb, std::vector<uint64_t>& out) {
    out.clear();
    size_t i = 0, j = 0, shared = 0;
    while (i < na || j < nb) {
        if (j == nb || (i < na && key_of(a[i]) < key_of(b[j]))) {
            out.push_back(a[i++]);
        } else if (i == na || key_of(b[j]) < key_of(a[i])) {
            out.push_back(b[j++]);
        } else {
            ++i;
            ++j;
            ++shared;
        }
    }
    return shared;
}

/// Closed segments [p, q] and [r, s] (2D) share a point, exactly for the given coordinates.
bool segments_meet(const double* p, const double* q, const double* r, const double* s) {
    const int a = orient2d(p, q, r), b = orient2d(p, q, s), c = orient2d(r, s, p), d = orient2d(r, s, q);
    if (a * b < 0 && c * d < 0) return true;
    auto on = [](const double* x, const double* y, const double* z) {  // z on [x, y], collinear
        return std::min(x[0], y[0]) <= z[0] && z[0] <= std::max(x[0], y[0]) && std::min(x[1], y[1]) <= z[1] &&
               z[1] <= std::max(x[1], y[1]);
    };
    return (a == 0 && on(p, q, r)) || (b == 0 && on(p, q, s)) || (c == 0 && on(r, s, p)) || (d == 0 && on(r, s, q));
}

/// The squared distance from x to the segment [p, q].
double point_segment_distance2(const double* x, const double* p, const double* q) {
    const double d[2] = {q[0] - p[0], q[1] - p[1]};
    const double len2 = d[0] * d[0] + d[1] * d[1];
    double t = len2 > 0.0 ? ((x[0] - p[0]) * d[0] + (x[1] - p[1]) * d[1]) / len2 : 0.0;
    t = std::clamp(t, 0.0, 1.0);
    const double dx = x[0] - p[0] - t * d[0], dy = x[1] - p[1] - t * d[1];
    return dx * dx + dy * dy;
}

/// True when every directed edge (u0 w0 u1 w1, a closed loop) turns counter-clockwise about
/// the loop's mean point and the loop goes round it once: the loop is star-shaped about that
/// point, so no two of its edges meet except neighbours at their shared end. O(edges); it holds
/// for regular patches (a flat grid's nodes), while on skin a few edges of a node's jagged
/// outline mostly turn back (4 % of the tests passed it on the 80K body), leaving the sweep.
bool star_shaped(const double* g, size_t count, double extent) {
    double c[2] = {0.0, 0.0};
    for (size_t i = 0; i < count; ++i) {
        c[0] += g[4 * i];
        c[1] += g[4 * i + 1];
    }
    c[0] /= static_cast<double>(count);
    c[1] /= static_cast<double>(count);
    const double margin = 1e-12 * extent * extent;
    size_t crossings = 0;  // of the ray from c along +u: each edge up across c's line crosses it
    for (size_t i = 0; i < count; ++i) {
        const double* p = g + 4 * i;
        const double* q = p + 2;
        if (!((p[0] - c[0]) * (q[1] - c[1]) - (p[1] - c[1]) * (q[0] - c[0]) > margin)) return false;
        crossings += p[1] < c[1] && q[1] >= c[1];
    }
    return crossings == 1;
}

/// True when the edges, projected along `axis` onto a plane, neither cross nor come nearer
/// than a millionth of their extent, except edges meeting at a shared end (which may not fold
/// back onto each other).
bool projects_without_crossing(const uint64_t* edges, size_t count, const float* axis, const float* positions,
                               PatchOutlines::Scratch& s) {
    const double a[3] = {axis[0], axis[1], axis[2]};
    // A basis of the plane: u across the axis from its least aligned coordinate axis.
    const int k = std::fabs(a[0]) <= std::fabs(a[1]) && std::fabs(a[0]) <= std::fabs(a[2]) ? 0
                  : std::fabs(a[1]) <= std::fabs(a[2])                                     ? 1
                                                                                           : 2;
    double e[3] = {0, 0, 0};
    e[k] = 1.0;
    double u[3] = {a[1] * e[2] - a[2] * e[1], a[2] * e[0] - a[0] * e[2], a[0] * e[1] - a[1] * e[0]};
    const double ul = std::sqrt(u[0] * u[0] + u[1] * u[1] + u[2] * u[2]);
    if (!(ul > 0.0)) return false;
    for (double& x : u) x /= ul;
    const double w[3] = {a[1] * u[2] - a[2] * u[1], a[2] * u[0] - a[0] * u[2], a[0] * u[1] - a[1] * u[0]};
    s.segments.resize(4 * count);
    double lo[2] = {std::numeric_limits<double>::infinity(), std::numeric_limits<double>::infinity()};
    double hi[2] = {-lo[0], -lo[1]};
    for (size_t i = 0; i < count; ++i)
        for (int end = 0; end < 2; ++end) {
            const float* p = positions + 3 * static_cast<size_t>(end ? to_vertex(edges[i]) : from_vertex(edges[i]));
            double* out = &s.segments[4 * i + 2 * end];
            out[0] = p[0] * u[0] + p[1] * u[1] + p[2] * u[2];
            out[1] = p[0] * w[0] + p[1] * w[1] + p[2] * w[2];
            for (int c = 0; c < 2; ++c) {
                lo[c] = std::min(lo[c], out[c]);
                hi[c] = std::max(hi[c], out[c]);
            }
        }
    const double tol = 1e-6 * std::max(hi[0] - lo[0], hi[1] - lo[1]);
    if (!std::isfinite(tol)) return false;
    const double* g = s.segments.data();
    if (star_shaped(g, count, std::max(hi[0] - lo[0], hi[1] - lo[1]))) return true;
    // Sweep along the longer side of the box: fewer edges overlap along it.
    const int along = hi[0] - lo[0] >= hi[1] - lo[1] ? 0 : 1, across = 1 - along;
    s.order.resize(count);
    s.starts.resize(count);
    for (size_t i = 0; i < count; ++i) {
        s.order[i] = static_cast<int32_t>(i);
        s.starts[i] = std::min(g[4 * i + along], g[4 * i + 2 + along]);
    }
    std::sort(s.order.begin(), s.order.end(), [&](int32_t x, int32_t y) { return s.starts[x] < s.starts[y]; });
    const double tol2 = tol * tol;
    for (size_t oi = 0; oi < count; ++oi) {
        const int32_t i = s.order[oi];
        const double* p = g + 4 * i;
        const double* q = p + 2;
        const double reach = std::max(p[along], q[along]) + tol;
        const double pq[2] = {q[0] - p[0], q[1] - p[1]};
        const double len2 = pq[0] * pq[0] + pq[1] * pq[1];
        for (size_t oj = oi + 1; oj < count && s.starts[s.order[oj]] <= reach; ++oj) {
            const int32_t j = s.order[oj];
            const double* r = g + 4 * j;
            const double* t = r + 2;
            if (std::max(r[across], t[across]) < std::min(p[across], q[across]) - tol ||
                std::max(p[across], q[across]) < std::min(r[across], t[across]) - tol)
                continue;
            // Both ends of [r, t] farther than tol on one side of the line through p, q: apart.
            const double cr = pq[0] * (r[1] - p[1]) - pq[1] * (r[0] - p[0]);
            const double ct = pq[0] * (t[1] - p[1]) - pq[1] * (t[0] - p[0]);
            if (((cr > 0.0 && ct > 0.0) || (cr < 0.0 && ct < 0.0)) && cr * cr > tol2 * len2 && ct * ct > tol2 * len2)
                continue;
            const int32_t ei[2] = {from_vertex(edges[i]), to_vertex(edges[i])};
            const int32_t ej[2] = {from_vertex(edges[j]), to_vertex(edges[j])};
            int si = -1, sj = -1;
            for (int x = 0; x < 2; ++x)
                for (int y = 0; y < 2; ++y)
                    if (ei[x] == ej[y]) si = x, sj = y;
            if (si >= 0) {  // neighbours along the outline: only a fold back onto each other counts
                const double* o = g + 4 * i + 2 * si;
                const double* x = g + 4 * i + 2 * (1 - si);
                const double* y = g + 4 * j + 2 * (1 - sj);
                const double dx[2] = {x[0] - o[0], x[1] - o[1]}, dy[2] = {y[0] - o[0], y[1] - o[1]};
                const double cross = dx[0] * dy[1] - dx[1] * dy[0], dot = dx[0] * dy[0] + dx[1] * dy[1];
                const double lx = std::sqrt(dx[0] * dx[0] + dx[1] * dx[1]);
                const double ly = std::sqrt(dy[0] * dy[0] + dy[1] * dy[1]);
                if (dot > 0.0 && std::fabs(cross) <= 1e-6 * lx * ly) return false;
                if (lx <= tol || ly <= tol) return false;
                continue;
            }
            if (segments_meet(p, q, r, t) || point_segment_distance2(p, r, t) <= tol2 ||
                point_segment_distance2(q, r, t) <= tol2 || point_segment_distance2(r, p, q) <= tol2 ||
                point_segment_distance2(t, p, q) <= tol2)
                return false;
        }
    }
    return true;
}

}  // namespace

void PatchOutlines::build(const TriangleBvh& bvh) {
    const std::vector<BvhNode>& nodes = bvh.nodes();
    const size_t N = nodes.size();
    offsets_.assign(N + 1, 0);
    edges_.clear();
    disk_.assign(N, 0);
    if (N == 0) return;
    const std::vector<uint8_t> good = regular_slots(bvh);
    std::vector<std::vector<uint64_t>> rows(N);
    std::vector<uint8_t> kept(N, 0);           // the row and vertex count are known
    std::vector<int32_t> vertex_count(N, -1);  // per node: its distinct vertices
    std::vector<int32_t> ends, left_vertices, right_vertices;
    std::vector<uint64_t> keys;
    // Children follow their parents in the array: a reverse sweep goes bottom-up.
    for (int i = static_cast<int>(N) - 1; i >= 0; --i) {
        const BvhNode& nd = nodes[i];
        std::vector<uint64_t>& row = rows[i];
        if (nd.leaf()) {
            bool ok = true;
            keys.clear();
            ends.clear();
            for (int s = nd.begin; s < nd.end; ++s) {
                ok = ok && good[s];
                const int32_t* v = bvh.vertices(s);
                for (int e = 0; e < 3; ++e) {
                    keys.push_back(directed_edge(v[e], v[(e + 1) % 3]));
                    ends.push_back(v[e]);
                }
            }
            if (!ok) continue;
            std::sort(keys.begin(), keys.end(), [](uint64_t x, uint64_t y) { return key_of(x) < key_of(y); });
            for (size_t a = 0; a < keys.size();) {
                size_t b = a;
                while (b < keys.size() && key_of(keys[b]) == key_of(keys[a])) ++b;
                if (b - a == 1) row.push_back(keys[a]);
                a = b;
            }
            std::sort(ends.begin(), ends.end());
            vertex_count[i] = static_cast<int32_t>(distinct(ends));
        } else {
            const int l = nd.first, r = nd.first + 1;
            if (!kept[l] || !kept[r]) continue;
            symmetric_difference(rows[l].data(), rows[l].size(), rows[r].data(), rows[r].size(), row);
            outline_vertices(rows[l].data(), rows[l].size(), left_vertices);
            outline_vertices(rows[r].data(), rows[r].size(), right_vertices);
            // Under regular_slots a vertex of both children lies on both outlines.
            vertex_count[i] = vertex_count[l] + vertex_count[r] -
                              static_cast<int32_t>(common(left_vertices.data(), left_vertices.size(),
                                                          right_vertices.data(), right_vertices.size()));
        }
        if (row.size() > static_cast<size_t>(kMaxOutline)) {
            vertex_count[i] = -1;
            std::vector<uint64_t>().swap(row);
            continue;
        }
        kept[i] = 1;
        // A disk: connected, its outline loops through distinct vertices, V - E + F = 1.
        const int64_t F = nd.end - nd.begin, B = static_cast<int64_t>(row.size());
        outline_vertices(row.data(), row.size(), ends);
        disk_[i] = bvh.connected(i) && !row.empty() && (3 * F + B) % 2 == 0 && every_vertex_on_two_edges(ends) &&
                   vertex_count[i] - (3 * F + B) / 2 + F == 1;
    }
    // Only the disks' outlines are ever tested.
    vertex_offsets_.assign(N + 1, 0);
    vertices_.clear();
    for (size_t i = 0; i < N; ++i) {
        if (disk_[i]) {
            edges_.insert(edges_.end(), rows[i].begin(), rows[i].end());
            outline_vertices(rows[i].data(), rows[i].size(), ends);
            ends.erase(std::unique(ends.begin(), ends.end()), ends.end());
            vertices_.insert(vertices_.end(), ends.begin(), ends.end());
        }
        offsets_[i + 1] = static_cast<uint32_t>(edges_.size());
        vertex_offsets_[i + 1] = static_cast<uint32_t>(vertices_.size());
    }
}

std::vector<uint64_t> PatchOutlines::outline(int node) const {
    if (!is_disk(node)) return {};
    std::vector<uint64_t> keys;
    for (uint32_t i = offsets_[node]; i < offsets_[node + 1]; ++i) keys.push_back(key_of(edges_[i]));
    return keys;
}

bool PatchOutlines::projects_simply(int node, const float* axis, const float* positions, Scratch& scratch) const {
    if (!is_disk(node)) return false;
    return projects_without_crossing(edges_.data() + offsets_[node], offsets_[node + 1] - offsets_[node], axis,
                                     positions, scratch);
}

bool PatchOutlines::union_projects_simply(int a, int b, const float* axis, const float* positions,
                                          Scratch& scratch) const {
    if (!is_disk(a) || !is_disk(b)) return false;
    const uint64_t* ea = edges_.data() + offsets_[a];
    const uint64_t* eb = edges_.data() + offsets_[b];
    const size_t na = offsets_[a + 1] - offsets_[a], nb = offsets_[b + 1] - offsets_[b];
    const size_t shared_edges = symmetric_difference(ea, na, eb, nb, scratch.edges);
    // Two disks glued along one chain of edges and nowhere else make a disk. The shared
    // edges lie on both outlines (loops), so they form chains, each with one vertex more
    // than edges, or the whole loop: one chain and no other shared vertex exactly when the
    // shared vertices are one more than the shared edges.
    const int32_t* va = vertices_.data() + vertex_offsets_[a];
    const int32_t* vb = vertices_.data() + vertex_offsets_[b];
    if (shared_edges == 0 || common(va, vertex_offsets_[a + 1] - vertex_offsets_[a], vb,
                                    vertex_offsets_[b + 1] - vertex_offsets_[b]) != shared_edges + 1)
        return false;
    return projects_without_crossing(scratch.edges.data(), scratch.edges.size(), axis, positions, scratch);
}

}  // namespace sd::anatomy
