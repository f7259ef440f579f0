#include "geometry/bvh.h"
#include "geometry/disjoint_sets.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <numeric>

namespace sd::anatomy {

namespace {

/// Up to 3 triangles sharing an edge with each triangle (-1 where none): for each edge the
/// first other triangle found on it.
std::vector<int32_t> edge_neighbours(const MeshTopology& m) {
    const int T = m.triangle_count();
    std::vector<int32_t> out(3 * static_cast<size_t>(T), -1);
    for (int t = 0; t < T; ++t) {
        const int32_t* tv = m.triangle(t);
        for (int e = 0; e < 3; ++e) {
            const int32_t a = tv[e], b = tv[(e + 1) % 3];
            for (uint32_t i = m.vertex_triangle_offsets[a]; i < m.vertex_triangle_offsets[a + 1]; ++i) {
                const int32_t o = m.vertex_triangles[i];
                if (o == t) continue;
                const int32_t* ov = m.triangle(o);
                if (ov[0] == b || ov[1] == b || ov[2] == b) {
                    out[3 * t + e] = o;
                    break;
                }
            }
        }
    }
    return out;
}

}  // namespace

void TriangleBvh::build(const MeshTopology& mesh, const std::vector<int32_t>& triangles, const float* positions,
                        int leaf_size, bool with_cones) {
    nodes_.clear();
    parent_.clear();
    with_cones_ = with_cones;
    const int n = static_cast<int>(triangles.size());
    slot_triangle_ = triangles;
    slot_of_triangle_.assign(mesh.triangle_count(), -1);
    if (n == 0) {
        slot_vertices_.clear();
        slot_box_.clear();
        slot_normal_.clear();
        leaf_of_slot_.clear();
        cones_.clear();
        connected_.clear();
        return;
    }
    leaf_size = std::max(1, leaf_size);

    std::vector<float> centroid(3 * static_cast<size_t>(mesh.triangle_count()));
    for (int32_t t : triangles) {
        const int32_t* v = mesh.triangle(t);
        for (int k = 0; k < 3; ++k)
            centroid[3 * t + k] = (positions[3 * v[0] + k] + positions[3 * v[1] + k] + positions[3 * v[2] + k]) / 3.0f;
    }
    const std::vector<int32_t> adj = edge_neighbours(mesh);
    std::vector<int32_t> order = triangles;  // triangle ids, partitioned in place
    std::vector<int32_t> mark(mesh.triangle_count(), -1), visit;
    int stamp = 0;

    // Top-down, keeping nodes edge-connected where the mesh allows (normal-cone culling
    // needs connected patches): a connected set is halved by a breadth-first search from
    // its extreme triangle along the longest axis (the first half visited is connected);
    // a disconnected set is split between its components, grouped along the longest axis.
    struct Task {
        int32_t node, begin, end;
    };
    std::vector<Task> stack;
    nodes_.push_back(BvhNode{});
    parent_.push_back(-1);
    stack.push_back({0, 0, n});
    while (!stack.empty()) {
        const Task task = stack.back();
        stack.pop_back();
        nodes_[task.node].begin = task.begin;
        nodes_[task.node].end = task.end;
        const int count = task.end - task.begin;
        if (count <= leaf_size) {
            nodes_[task.node].first = task.begin;
            nodes_[task.node].count = count;
            continue;
        }
        float lo[3] = {1e30f, 1e30f, 1e30f}, hi[3] = {-1e30f, -1e30f, -1e30f};
        for (int i = task.begin; i < task.end; ++i)
            for (int k = 0; k < 3; ++k) {
                lo[k] = std::min(lo[k], centroid[3 * order[i] + k]);
                hi[k] = std::max(hi[k], centroid[3 * order[i] + k]);
            }
        const int axis = (hi[0] - lo[0] >= hi[1] - lo[1] && hi[0] - lo[0] >= hi[2] - lo[2])
                             ? 0
                             : (hi[1] - lo[1] >= hi[2] - lo[2] ? 1 : 2);
        // Components of the set (breadth-first over shared edges within it).
        ++stamp;
        for (int i = task.begin; i < task.end; ++i) mark[order[i]] = stamp;
        std::vector<std::vector<int32_t>> components;
        {
            const int done = ++stamp;  // mark == done: already in a component
            for (int i = task.begin; i < task.end; ++i) {
                const int32_t seed = order[i];
                if (mark[seed] != done - 1) continue;
                std::vector<int32_t> comp{seed};
                mark[seed] = done;
                for (size_t q = 0; q < comp.size(); ++q)
                    for (int e = 0; e < 3; ++e) {
                        const int32_t o = adj[3 * static_cast<size_t>(comp[q]) + e];
                        if (o >= 0 && mark[o] == done - 1) {
                            mark[o] = done;
                            comp.push_back(o);
                        }
                    }
                components.push_back(std::move(comp));
            }
        }
        const int half = count / 2;
        int mid = task.begin + half;
        if (components.size() > 1) {
            // Order the components along the axis, split where half the triangles are.
            std::vector<std::pair<float, size_t>> keyed;
            for (size_t c = 0; c < components.size(); ++c) {
                double sum = 0.0;
                for (int32_t t : components[c]) sum += centroid[3 * t + axis];
                keyed.push_back({static_cast<float>(sum / static_cast<double>(components[c].size())), c});
            }
            std::sort(keyed.begin(), keyed.end());
            int at = task.begin;
            mid = -1;
            for (const auto& [key, c] : keyed) {
                if (mid < 0 && at > task.begin && at - task.begin + static_cast<int>(components[c].size()) / 2 > half)
                    mid = at;
                for (int32_t t : components[c]) order[at++] = t;
            }
            if (mid < 0 || mid >= task.end) mid = task.begin + half;  // one dominant component: cut it
        } else {
            // Breadth-first from the extreme triangle; the first half visited is one child.
            int32_t seed = order[task.begin];
            for (int i = task.begin; i < task.end; ++i)
                if (centroid[3 * order[i] + axis] < centroid[3 * seed + axis]) seed = order[i];
            ++stamp;
            const int seen = stamp;
            visit.clear();
            visit.push_back(seed);
            mark[seed] = seen;
            for (size_t q = 0; q < visit.size(); ++q)
                for (int e = 0; e < 3; ++e) {
                    const int32_t o = adj[3 * static_cast<size_t>(visit[q]) + e];
                    if (o >= 0 && mark[o] == seen - 1) {  // in the set (its component stamp)
                        mark[o] = seen;
                        visit.push_back(o);
                    }
                }
            // visit holds the whole (connected) set in breadth-first order. The first half is
            // connected; of the rest, every component but the largest joins it (each touches
            // the first half, the set being connected), so both children are connected.
            ++stamp;
            const int rest = stamp;
            for (size_t i = static_cast<size_t>(half); i < visit.size(); ++i) mark[visit[i]] = rest;
            std::vector<std::vector<int32_t>> parts;
            const int taken = ++stamp;
            for (size_t i = static_cast<size_t>(half); i < visit.size(); ++i) {
                if (mark[visit[i]] != rest) continue;
                std::vector<int32_t> comp{visit[i]};
                mark[visit[i]] = taken;
                for (size_t q = 0; q < comp.size(); ++q)
                    for (int e = 0; e < 3; ++e) {
                        const int32_t o = adj[3 * static_cast<size_t>(comp[q]) + e];
                        if (o >= 0 && mark[o] == rest) {
                            mark[o] = taken;
                            comp.push_back(o);
                        }
                    }
                parts.push_back(std::move(comp));
            }
            size_t largest = 0;
            for (size_t c = 1; c < parts.size(); ++c)
                if (parts[c].size() > parts[largest].size()) largest = c;
            int at = task.begin;
            for (int i = 0; i < half; ++i) order[at++] = visit[i];
            for (size_t c = 0; c < parts.size(); ++c)
                if (c != largest)
                    for (int32_t t : parts[c]) order[at++] = t;
            mid = at;
            for (int32_t t : parts[largest]) order[at++] = t;
        }
        const int32_t left = static_cast<int32_t>(nodes_.size());
        nodes_[task.node].first = left;
        nodes_[task.node].count = 0;
        nodes_.push_back(BvhNode{});
        nodes_.push_back(BvhNode{});
        parent_.push_back(task.node);
        parent_.push_back(task.node);
        stack.push_back({left + 1, mid, task.end});
        stack.push_back({left, task.begin, mid});
    }

    slot_triangle_.resize(n);
    slot_vertices_.resize(3 * static_cast<size_t>(n));
    for (int s = 0; s < n; ++s) {
        slot_triangle_[s] = order[s];
        slot_of_triangle_[slot_triangle_[s]] = s;
        const int32_t* v = mesh.triangle(slot_triangle_[s]);
        for (int k = 0; k < 3; ++k) slot_vertices_[3 * s + k] = v[k];
    }
    dirty_flag_.assign(nodes_.size(), 0);
    dirty_.clear();
    leaf_of_slot_.assign(n, -1);
    for (int i = 0; i < static_cast<int>(nodes_.size()); ++i)
        if (nodes_[i].leaf())
            for (int s = nodes_[i].begin; s < nodes_[i].end; ++s) leaf_of_slot_[s] = i;
    slot_box_.assign(6 * static_cast<size_t>(n), 0.0f);
    slot_normal_.assign(with_cones ? 3 * static_cast<size_t>(n) : 0, 0.0f);
    cones_.assign(with_cones ? nodes_.size() : 0, NormalCone{{0, 0, 0}, -2.0f});
    connected_.assign(nodes_.size(), 0);

    if (with_cones) {
        // Edge-connectivity of each node's triangles (static: the topology never changes).
        for (size_t i = 0; i < nodes_.size(); ++i) {
            const BvhNode& nd = nodes_[i];
            DisjointSets sets(static_cast<size_t>(nd.end - nd.begin));
            int components = nd.end - nd.begin;
            for (int s = nd.begin; s < nd.end; ++s)
                for (int e = 0; e < 3; ++e) {
                    const int32_t o = adj[3 * static_cast<size_t>(slot_triangle_[s]) + e];
                    if (o < 0) continue;
                    const int32_t os = slot_of_triangle_[o];
                    if (os >= nd.begin && os < nd.end && sets.unite(s - nd.begin, os - nd.begin)) --components;
                }
            connected_[i] = components == 1;
        }
        // Border: the slots just outside each node across an edge.
        border_offsets_.assign(nodes_.size() + 1, 0);
        border_slots_.clear();
        std::vector<int32_t> row;
        for (size_t i = 0; i < nodes_.size(); ++i) {
            const BvhNode& nd = nodes_[i];
            row.clear();
            for (int s = nd.begin; s < nd.end; ++s)
                for (int e = 0; e < 3; ++e) {
                    const int32_t o = adj[3 * static_cast<size_t>(slot_triangle_[s]) + e];
                    if (o < 0) continue;
                    const int32_t os = slot_of_triangle_[o];
                    if (os >= 0 && (os < nd.begin || os >= nd.end)) row.push_back(os);
                }
            std::sort(row.begin(), row.end());
            row.erase(std::unique(row.begin(), row.end()), row.end());
            border_slots_.insert(border_slots_.end(), row.begin(), row.end());
            border_offsets_[i + 1] = static_cast<uint32_t>(border_slots_.size());
        }
    }
    // Descendant ranges, and a cut of the tree into subtrees for the parallel refit.
    descendants_end_.assign(nodes_.size(), 0);
    for (int i = static_cast<int>(nodes_.size()) - 1; i >= 0; --i)
        descendants_end_[i] =
            nodes_[i].leaf()
                ? i + 1
                : std::max({descendants_end_[nodes_[i].first], descendants_end_[nodes_[i].first + 1], i + 1});
    subtree_roots_.assign(1, 0);
    top_nodes_.clear();
    while (subtree_roots_.size() < 64) {
        // Split the largest inner subtree.
        size_t best = subtree_roots_.size();
        for (size_t r = 0; r < subtree_roots_.size(); ++r) {
            const BvhNode& nd = nodes_[subtree_roots_[r]];
            if (!nd.leaf() && nd.end - nd.begin > 256 &&
                (best == subtree_roots_.size() ||
                 nd.end - nd.begin > nodes_[subtree_roots_[best]].end - nodes_[subtree_roots_[best]].begin))
                best = r;
        }
        if (best == subtree_roots_.size()) break;
        const int root = subtree_roots_[best];
        top_nodes_.push_back(root);  // parents before children
        subtree_roots_[best] = nodes_[root].first;
        subtree_roots_.push_back(nodes_[root].first + 1);
    }
    refit(positions);
}

void TriangleBvh::compute_slot(const float* p, int s) {
    const int32_t* v = &slot_vertices_[3 * static_cast<size_t>(s)];
    const float* a = p + 3 * static_cast<size_t>(v[0]);
    const float* b = p + 3 * static_cast<size_t>(v[1]);
    const float* c = p + 3 * static_cast<size_t>(v[2]);
    float* box = &slot_box_[6 * static_cast<size_t>(s)];
    for (int k = 0; k < 3; ++k) {
        box[k] = std::min({a[k], b[k], c[k]});
        box[3 + k] = std::max({a[k], b[k], c[k]});
    }
    if (!with_cones_) return;
    const float u[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]};
    const float w[3] = {c[0] - a[0], c[1] - a[1], c[2] - a[2]};
    float n[3] = {u[1] * w[2] - u[2] * w[1], u[2] * w[0] - u[0] * w[2], u[0] * w[1] - u[1] * w[0]};
    const float len = std::sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
    float* out = &slot_normal_[3 * static_cast<size_t>(s)];
    if (len > 0.0f && std::isfinite(len)) {
        for (int k = 0; k < 3; ++k) out[k] = n[k] / len;
    } else {
        out[0] = out[1] = out[2] = 0.0f;  // degenerate: no normal, no cone
    }
}

void TriangleBvh::refit_leaf(const float* p, int i) {
    (void)p;
    BvhNode& nd = nodes_[i];
    for (int k = 0; k < 3; ++k) {
        nd.lo[k] = 1e30f;
        nd.hi[k] = -1e30f;
    }
    for (int s = nd.begin; s < nd.end; ++s) {
        const float* box = &slot_box_[6 * static_cast<size_t>(s)];
        for (int k = 0; k < 3; ++k) {
            nd.lo[k] = std::min(nd.lo[k], box[k]);
            nd.hi[k] = std::max(nd.hi[k], box[3 + k]);
        }
    }
    if (!with_cones_) return;
    float axis[3] = {0, 0, 0};
    bool degenerate = false;
    for (int s = nd.begin; s < nd.end; ++s) {
        const float* n = &slot_normal_[3 * static_cast<size_t>(s)];
        if (n[0] == 0.0f && n[1] == 0.0f && n[2] == 0.0f) degenerate = true;
        for (int k = 0; k < 3; ++k) axis[k] += n[k];
    }
    NormalCone& cone = cones_[i];
    const float len = std::sqrt(axis[0] * axis[0] + axis[1] * axis[1] + axis[2] * axis[2]);
    if (degenerate || !(len > 1e-6f)) {
        cone = NormalCone{{0, 0, 1}, -2.0f};
        return;
    }
    float c = 1.0f;
    for (int k = 0; k < 3; ++k) cone.axis[k] = axis[k] / len;
    for (int s = nd.begin; s < nd.end; ++s) {
        const float* n = &slot_normal_[3 * static_cast<size_t>(s)];
        c = std::min(c, n[0] * cone.axis[0] + n[1] * cone.axis[1] + n[2] * cone.axis[2]);
    }
    cone.cos_half_angle = c;
}

bool TriangleBvh::adjacent(int a, int b) const {
    const BvhNode& nb = nodes_[b];
    const auto first = border_slots_.begin() + border_offsets_[a];
    const auto last = border_slots_.begin() + border_offsets_[a + 1];
    const auto it = std::lower_bound(first, last, nb.begin);
    return it != last && *it < nb.end;
}

namespace {

/// A cone bounding two cones (see refit_inner).
NormalCone merge(const NormalCone& cl, const NormalCone& cr) {
    if (cl.cos_half_angle < -1.0f || cr.cos_half_angle < -1.0f) return NormalCone{{0, 0, 1}, -2.0f};
    float axis[3] = {cl.axis[0] + cr.axis[0], cl.axis[1] + cr.axis[1], cl.axis[2] + cr.axis[2]};
    const float len = std::sqrt(axis[0] * axis[0] + axis[1] * axis[1] + axis[2] * axis[2]);
    if (!(len > 1e-6f)) return NormalCone{{0, 0, 1}, -2.0f};
    NormalCone cone;
    for (int k = 0; k < 3; ++k) cone.axis[k] = axis[k] / len;
    // Every normal of child c is within theta_c + alpha_c of the new axis, where theta_c is
    // the angle between the axes and alpha_c the child's half-angle:
    //   cos(theta + alpha) = cos theta cos alpha - sin theta sin alpha,
    // valid while theta + alpha <= pi, i.e. while sin(theta + alpha) >= 0.
    float c = 1.0f;
    for (const NormalCone* child : {&cl, &cr}) {
        const float ct = std::clamp(
            child->axis[0] * cone.axis[0] + child->axis[1] * cone.axis[1] + child->axis[2] * cone.axis[2], -1.0f, 1.0f);
        const float st = std::sqrt(std::max(0.0f, 1.0f - ct * ct));
        const float ca = std::clamp(child->cos_half_angle, -1.0f, 1.0f);
        const float sa = std::sqrt(std::max(0.0f, 1.0f - ca * ca));
        if (st * ca + ct * sa < 0.0f) return NormalCone{{0, 0, 1}, -2.0f};
        // A small allowance for rounding keeps the bound conservative.
        c = std::min(c, ct * ca - st * sa - 1e-6f);
    }
    cone.cos_half_angle = c;
    return cone;
}

}  // namespace

NormalCone TriangleBvh::merged_cone(int a, int b) const { return merge(cones_[a], cones_[b]); }

void TriangleBvh::refit_inner(int i) {
    BvhNode& nd = nodes_[i];
    const BvhNode& l = nodes_[nd.first];
    const BvhNode& r = nodes_[nd.first + 1];
    for (int k = 0; k < 3; ++k) {
        nd.lo[k] = std::min(l.lo[k], r.lo[k]);
        nd.hi[k] = std::max(l.hi[k], r.hi[k]);
    }
    if (!with_cones_) return;
    cones_[i] = merge(cones_[nd.first], cones_[nd.first + 1]);
}

void TriangleBvh::refit(const float* positions) {
    for (int32_t i : dirty_) dirty_flag_[i] = 0;
    dirty_.clear();
    // Independent subtrees in parallel (each one's descendants are the contiguous node
    // range [first child, descendants_end), its triangles the slots [begin, end)), then the
    // few nodes above them.
    tbb::parallel_for(size_t(0), subtree_roots_.size(), [&](size_t r) {
        const int root = subtree_roots_[r];
        const BvhNode& nd = nodes_[root];
        for (int s = nd.begin; s < nd.end; ++s) compute_slot(positions, s);
        if (!nd.leaf())
            for (int i = descendants_end_[root] - 1; i >= nd.first; --i) {
                if (nodes_[i].leaf())
                    refit_leaf(positions, i);
                else
                    refit_inner(i);
            }
        if (nd.leaf())
            refit_leaf(positions, root);
        else
            refit_inner(root);
    });
    for (size_t i = top_nodes_.size(); i-- > 0;) refit_inner(top_nodes_[i]);
}

void TriangleBvh::refit_slots(const float* positions, const std::vector<int32_t>& slots) {
    for (int32_t i : dirty_) dirty_flag_[i] = 0;
    dirty_.clear();
    // Flag the leaves of the slots and their ancestors (each once), then refit the flagged
    // nodes children first: a reverse sweep over the node array.
    for (int32_t s : slots) {
        compute_slot(positions, s);
        for (int32_t n = leaf_of_slot_[s]; n >= 0 && !dirty_flag_[n]; n = parent_[n]) {
            dirty_flag_[n] = 1;
            dirty_.push_back(n);
        }
    }
    if (dirty_.size() * 8 < nodes_.size()) {
        std::sort(dirty_.begin(), dirty_.end());
        for (size_t i = dirty_.size(); i-- > 0;) {
            if (nodes_[dirty_[i]].leaf())
                refit_leaf(positions, dirty_[i]);
            else
                refit_inner(dirty_[i]);
        }
    } else {
        for (int i = static_cast<int>(nodes_.size()) - 1; i >= 0; --i) {
            if (!dirty_flag_[i]) continue;
            if (nodes_[i].leaf())
                refit_leaf(positions, i);
            else
                refit_inner(i);
        }
    }
}

bool TriangleBvh::ray_first_hit(const float* p, const double* o, const double* d, double t_max, double* t_out,
                                int32_t* tri_out, bool farthest) const {
    if (nodes_.empty()) return false;
    double best = farthest ? -1.0 : t_max;
    int32_t best_tri = -1;
    const double inv[3] = {1.0 / d[0], 1.0 / d[1], 1.0 / d[2]};
    int32_t stack[128];
    int top = 0;
    stack[top++] = 0;
    while (top > 0) {
        const BvhNode& nd = nodes_[stack[--top]];
        // Slab test.
        double t0 = farthest ? std::max(0.0, best) : 0.0, t1 = farthest ? t_max : best;
        bool miss = false;
        for (int k = 0; k < 3 && !miss; ++k) {
            double a = (nd.lo[k] - o[k]) * inv[k], b = (nd.hi[k] - o[k]) * inv[k];
            if (a > b) std::swap(a, b);
            if (std::isnan(a) || std::isnan(b)) {  // d[k] == 0 and o on a slab plane
                if (o[k] < nd.lo[k] || o[k] > nd.hi[k]) miss = true;
                continue;
            }
            t0 = std::max(t0, a);
            t1 = std::min(t1, b);
            if (t0 > t1) miss = true;
        }
        if (miss) continue;
        if (!nd.leaf()) {
            if (top + 2 > 128) continue;  // depth beyond any tree built here
            stack[top++] = nd.first;
            stack[top++] = nd.first + 1;
            continue;
        }
        for (int s = nd.begin; s < nd.end; ++s) {
            const int32_t* v = &slot_vertices_[3 * static_cast<size_t>(s)];
            const float* a = p + 3 * static_cast<size_t>(v[0]);
            const float* b = p + 3 * static_cast<size_t>(v[1]);
            const float* c = p + 3 * static_cast<size_t>(v[2]);
            const double e1[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]};
            const double e2[3] = {c[0] - a[0], c[1] - a[1], c[2] - a[2]};
            const double q[3] = {d[1] * e2[2] - d[2] * e2[1], d[2] * e2[0] - d[0] * e2[2], d[0] * e2[1] - d[1] * e2[0]};
            const double det = e1[0] * q[0] + e1[1] * q[1] + e1[2] * q[2];
            if (std::abs(det) < 1e-300) continue;
            const double inv_det = 1.0 / det;
            const double sv[3] = {o[0] - a[0], o[1] - a[1], o[2] - a[2]};
            const double u = (sv[0] * q[0] + sv[1] * q[1] + sv[2] * q[2]) * inv_det;
            if (u < 0.0 || u > 1.0) continue;
            const double r[3] = {sv[1] * e1[2] - sv[2] * e1[1], sv[2] * e1[0] - sv[0] * e1[2],
                                 sv[0] * e1[1] - sv[1] * e1[0]};
            const double w = (d[0] * r[0] + d[1] * r[1] + d[2] * r[2]) * inv_det;
            if (w < 0.0 || u + w > 1.0) continue;
            const double t = (e2[0] * r[0] + e2[1] * r[1] + e2[2] * r[2]) * inv_det;
            if (t >= 0.0 && t <= t_max && (farthest ? t >= best : t <= best)) {
                best = t;
                best_tri = slot_triangle_[s];
            }
        }
    }
    if (best_tri < 0) return false;
    *t_out = best;
    *tri_out = best_tri;
    return true;
}

}  // namespace sd::anatomy
