#include "geometry/cross_section.h"

#include "geometry/mesh_halfedge.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace sd::fit {

std::vector<SectionLoop> cut_mesh(const FitMesh& fm, const dvec3& origin, const dvec3& normal) {
    const OpenMeshTri& m = fm.halfedge().mesh;
    const std::vector<int32_t>& input = fm.halfedge().input_vertex;
    const std::vector<dvec3>& x = fm.positions();
    const size_t nv = m.n_vertices(), nf = m.n_faces();
    std::vector<double> d(nv);
    std::vector<char> positive(nv);
    for (size_t i = 0; i < nv; ++i) {
        d[i] = glm::dot(x[input[i]] - origin, normal);
        positive[i] = d[i] >= 0.0;
    }
    const auto crosses = [&](OpenMesh::HalfedgeHandle h) {
        return positive[m.from_vertex_handle(h).idx()] != positive[m.to_vertex_handle(h).idx()];
    };
    // The crossing half-edge of face f that leaves the positive side (out = true) or
    // enters it (out = false). A triangle with mixed sides has exactly one of each.
    const auto crossing = [&](OpenMesh::FaceHandle f, bool out) {
        OpenMesh::HalfedgeHandle h = m.halfedge_handle(f);
        for (int i = 0; i < 3; ++i, h = m.next_halfedge_handle(h))
            if (crosses(h) && positive[m.from_vertex_handle(h).idx()] == (out ? 1 : 0)) return h;
        return OpenMesh::HalfedgeHandle();
    };
    const auto point = [&](OpenMesh::HalfedgeHandle h) {
        // Always interpolate from the lower OpenMesh index, so both faces of an edge agree.
        int a = m.from_vertex_handle(h).idx(), b = m.to_vertex_handle(h).idx();
        if (a > b) std::swap(a, b);
        SectionPoint s;
        s.v0 = input[a];
        s.v1 = input[b];
        s.t = d[a] / (d[a] - d[b]);
        s.p = x[s.v0] + s.t * (x[s.v1] - x[s.v0]);
        return s;
    };
    const auto mixed = [&](OpenMesh::FaceHandle f) {
        OpenMesh::HalfedgeHandle h = m.halfedge_handle(f);
        const char s0 = positive[m.from_vertex_handle(h).idx()];
        for (int i = 0; i < 2; ++i) {
            h = m.next_halfedge_handle(h);
            if (positive[m.from_vertex_handle(h).idx()] != s0) return true;
        }
        return false;
    };

    std::vector<SectionLoop> loops;
    std::vector<char> visited(nf, 0);
    for (size_t fi = 0; fi < nf; ++fi) {
        const OpenMesh::FaceHandle f0(static_cast<int>(fi));
        if (visited[fi] || !mixed(f0)) continue;
        visited[fi] = 1;
        SectionLoop loop;
        loop.points.push_back(point(crossing(f0, false)));
        OpenMesh::FaceHandle f = f0;
        bool open = false;
        for (;;) {
            const OpenMesh::HalfedgeHandle h = crossing(f, true);
            const OpenMesh::FaceHandle g = m.face_handle(m.opposite_halfedge_handle(h));
            if (g == f0) break;  // back at the start: closed (its entry point is points[0])
            loop.points.push_back(point(h));
            if (!g.is_valid() || visited[g.idx()]) {
                open = !g.is_valid();
                break;
            }
            visited[g.idx()] = 1;
            f = g;
        }
        if (open) {
            // Reached a border: walk backwards from the start to the other border.
            std::vector<SectionPoint> back;
            f = f0;
            for (;;) {
                const OpenMesh::HalfedgeHandle h = crossing(f, false);
                const OpenMesh::FaceHandle g = m.face_handle(m.opposite_halfedge_handle(h));
                if (!g.is_valid() || visited[g.idx()]) break;
                visited[g.idx()] = 1;
                back.push_back(point(crossing(g, false)));
                f = g;
            }
            loop.points.insert(loop.points.begin(), back.rbegin(), back.rend());
            loop.closed = false;
        }
        if (loop.points.size() >= 3) loops.push_back(std::move(loop));
    }
    return loops;
}

PlaneFrame::PlaneFrame(const dvec3& o, const dvec3& normal, const dvec3& reference)
    : origin(o), n(glm::normalize(normal)) {
    dvec3 r = reference - glm::dot(reference, n) * n;
    if (glm::length(r) < 1e-6 * (glm::length(reference) + 1e-300)) {
        // Any direction not parallel to n.
        const dvec3 axis = std::abs(n.x) < 0.6 ? dvec3(1, 0, 0) : dvec3(0, 1, 0);
        r = axis - glm::dot(axis, n) * n;
    }
    u = glm::normalize(r);
    v = glm::cross(n, u);
}

double polygon_area(const std::vector<dvec2>& p) {
    double s = 0.0;
    const size_t n = p.size();
    for (size_t i = 0; i < n; ++i) {
        const dvec2& a = p[i];
        const dvec2& b = p[(i + 1) % n];
        s += a.x * b.y - a.y * b.x;
    }
    return 0.5 * s;
}

dvec2 polygon_centroid(const std::vector<dvec2>& p) {
    const size_t n = p.size();
    if (n == 0) return dvec2(0.0);
    // Relative to the first point, which keeps the sums well conditioned far from 0.
    const dvec2 o = p[0];
    double area = 0.0;
    dvec2 c(0.0), mean(0.0);
    for (size_t i = 0; i < n; ++i) {
        const dvec2 a = p[i] - o, b = p[(i + 1) % n] - o;
        const double cr = a.x * b.y - a.y * b.x;
        area += cr;
        c += (a + b) * cr;
        mean += p[i];
    }
    mean /= static_cast<double>(n);
    double extent = 0.0;
    for (const dvec2& q : p) extent = std::max(extent, glm::length(q - mean));
    if (!(std::abs(area) > 1e-12 * extent * extent)) return mean;
    return o + c / (3.0 * area);
}

bool polygon_contains(const std::vector<dvec2>& p, const dvec2& q) {
    int winding = 0;
    const size_t n = p.size();
    for (size_t i = 0; i < n; ++i) {
        const dvec2& a = p[i];
        const dvec2& b = p[(i + 1) % n];
        const double side = (b.x - a.x) * (q.y - a.y) - (q.x - a.x) * (b.y - a.y);
        if (a.y <= q.y) {
            if (b.y > q.y && side > 0.0) ++winding;
        } else if (b.y <= q.y && side < 0.0) {
            --winding;
        }
    }
    return winding != 0;
}

double polygon_distance(const std::vector<dvec2>& p, const dvec2& q) {
    double best = std::numeric_limits<double>::infinity();
    const size_t n = p.size();
    for (size_t i = 0; i < n; ++i) {
        const dvec2& a = p[i];
        const dvec2 e = p[(i + 1) % n] - a;
        const double len2 = glm::dot(e, e);
        const double s = len2 > 0.0 ? std::clamp(glm::dot(q - a, e) / len2, 0.0, 1.0) : 0.0;
        best = std::min(best, glm::length(q - (a + s * e)));
    }
    return best;
}

LoopPick pick_loop(const std::vector<std::vector<dvec2>>& polygons, const dvec2& q, double max_distance) {
    LoopPick inside, nearest;
    inside.distance = nearest.distance = std::numeric_limits<double>::infinity();
    for (size_t i = 0; i < polygons.size(); ++i) {
        if (polygons[i].size() < 3) continue;
        const double dist = polygon_distance(polygons[i], q);
        if (polygon_contains(polygons[i], q)) {
            if (dist < inside.distance) inside = {static_cast<int>(i), true, dist};
        } else if (dist < nearest.distance) {
            nearest = {static_cast<int>(i), false, dist};
        }
    }
    if (inside.loop >= 0) return inside;
    if (nearest.loop >= 0 && nearest.distance <= max_distance) return nearest;
    return LoopPick{};
}

}  // namespace sd::fit
