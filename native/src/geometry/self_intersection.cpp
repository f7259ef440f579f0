#include "geometry/self_intersection.h"

#include "geometry/patch_outline.h"
#include "geometry/triangle_intersection.h"

#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>

#include <algorithm>

namespace sd::anatomy {

namespace {

// A patch whose normals all lie within acos(0.02) ~ 88.9 degrees of one axis is skipped.
constexpr float kConeCull = 0.02f;

bool boxes_overlap(const float* lo_a, const float* hi_a, const float* lo_b, const float* hi_b) {
    return lo_a[0] <= hi_b[0] && lo_b[0] <= hi_a[0] && lo_a[1] <= hi_b[1] && lo_b[1] <= hi_a[1] && lo_a[2] <= hi_b[2] &&
           lo_b[2] <= hi_a[2];
}

struct Task {
    int32_t a, b;  // a == b: self test of node a
};

struct Output {
    std::vector<TrianglePair> pairs;
    CollisionStats stats;
    PatchOutlines::Scratch scratch;
};

class Traversal {
public:
    /// @param cull  normal-cone culling
    /// @param outlines  the nodes' outlines, which the culling then requires (nullptr: the cone
    ///                  and the patch's connectivity alone, CpuCollisionOptions::outline_check)
    /// @param only_dirty  skip what involves no dirty node (TriangleBvh::refit_slots)
    Traversal(const TriangleBvh& bvh, const float* positions, bool cull, const PatchOutlines* outlines,
              bool only_dirty = false)
        : bvh_(bvh), p_(positions), cull_(cull), outlines_(outlines), only_dirty_(only_dirty) {}

    /// A disk whose normals lie within 90 degrees of an axis, and whose outline projected
    /// along it does not cross itself, cannot meet itself.
    bool culled(int n, Output& out) const {
        if (only_dirty_ && !bvh_.dirty(n)) return true;
        if (!cull_ || !bvh_.connected(n) || !(bvh_.cone(n).cos_half_angle > kConeCull)) return false;
        return outlines_ == nullptr || outlines_->projects_simply(n, bvh_.cone(n).axis, p_, out.scratch);
    }

    void test_slots(int s, int t, Output& out) const {
        const int32_t* va = bvh_.vertices(s);
        const int32_t* vb = bvh_.vertices(t);
        if (share_vertex(va, vb)) return;
        const float* ba = bvh_.box(s);
        const float* bb = bvh_.box(t);
        if (!boxes_overlap(ba, ba + 3, bb, bb + 3)) return;
        ++out.stats.triangle_tests;
        if (triangles_intersect(p_ + 3 * static_cast<size_t>(va[0]), p_ + 3 * static_cast<size_t>(va[1]),
                                p_ + 3 * static_cast<size_t>(va[2]), p_ + 3 * static_cast<size_t>(vb[0]),
                                p_ + 3 * static_cast<size_t>(vb[1]), p_ + 3 * static_cast<size_t>(vb[2]))) {
            const int32_t x = bvh_.triangle(s), y = bvh_.triangle(t);
            out.pairs.push_back({std::min(x, y), std::max(x, y)});
        }
    }

    void self(int n, Output& out) const {
        if (culled(n, out)) return;
        const BvhNode& nd = bvh_.node(n);
        if (nd.leaf()) {
            for (int s = nd.begin; s < nd.end; ++s)
                for (int t = s + 1; t < nd.end; ++t) test_slots(s, t, out);
            return;
        }
        self(nd.first, out);
        self(nd.first + 1, out);
        pair(nd.first, nd.first + 1, out);
    }

    /// Two adjacent disks whose normals together stay within 90 degrees of one axis, joined
    /// into one disk whose outline does not cross itself along that axis: no pair between
    /// them can intersect.
    bool culled_pair(int a, int b, Output& out) const {
        if (only_dirty_ && !bvh_.dirty(a) && !bvh_.dirty(b)) return true;
        if (!cull_ || !bvh_.connected(a) || !bvh_.connected(b)) return false;
        // Siblings' union is their parent, whose own test (self) failed: so would this one.
        if (outlines_ != nullptr && bvh_.siblings(a, b)) return false;
        // Cheap necessary conditions before the merged cone: each cone within 90 degrees
        // and the axes less than 180 degrees apart.
        const NormalCone& ca = bvh_.cone(a);
        const NormalCone& cb = bvh_.cone(b);
        if (!(ca.cos_half_angle > kConeCull) || !(cb.cos_half_angle > kConeCull) ||
            !(ca.axis[0] * cb.axis[0] + ca.axis[1] * cb.axis[1] + ca.axis[2] * cb.axis[2] > 0.0f))
            return false;
        const NormalCone merged = bvh_.merged_cone(a, b);
        return merged.cos_half_angle > kConeCull && bvh_.adjacent(a, b) &&
               (outlines_ == nullptr || outlines_->union_projects_simply(a, b, merged.axis, p_, out.scratch));
    }

    void pair(int a, int b, Output& out) const {
        const BvhNode& na = bvh_.node(a);
        const BvhNode& nb = bvh_.node(b);
        ++out.stats.node_pairs;
        if (!boxes_overlap(na.lo, na.hi, nb.lo, nb.hi) || culled_pair(a, b, out)) return;
        if (na.leaf() && nb.leaf()) {
            for (int s = na.begin; s < na.end; ++s)
                for (int t = nb.begin; t < nb.end; ++t) test_slots(s, t, out);
            return;
        }
        if (na.leaf() || (!nb.leaf() && nb.end - nb.begin > na.end - na.begin)) {
            pair(a, nb.first, out);
            pair(a, nb.first + 1, out);
        } else {
            pair(na.first, b, out);
            pair(na.first + 1, b, out);
        }
    }

    /// Splits the root's work into independent tasks for the threads.
    std::vector<Task> tasks(size_t wanted) const {
        Output scratch;
        std::vector<Task> open{{0, 0}}, done;
        while (!open.empty() && open.size() + done.size() < wanted) {
            std::vector<Task> next;
            for (const Task& t : open) {
                if (t.a == t.b) {
                    const BvhNode& nd = bvh_.node(t.a);
                    if (culled(t.a, scratch)) continue;
                    if (nd.leaf()) {
                        done.push_back(t);
                        continue;
                    }
                    next.push_back({nd.first, nd.first});
                    next.push_back({nd.first + 1, nd.first + 1});
                    next.push_back({nd.first, nd.first + 1});
                } else {
                    const BvhNode& na = bvh_.node(t.a);
                    const BvhNode& nb = bvh_.node(t.b);
                    if (!boxes_overlap(na.lo, na.hi, nb.lo, nb.hi) || culled_pair(t.a, t.b, scratch)) continue;
                    if (na.leaf() && nb.leaf()) {
                        done.push_back(t);
                    } else if (na.leaf() || (!nb.leaf() && nb.end - nb.begin > na.end - na.begin)) {
                        next.push_back({t.a, nb.first});
                        next.push_back({t.a, nb.first + 1});
                    } else {
                        next.push_back({na.first, t.b});
                        next.push_back({na.first + 1, t.b});
                    }
                }
            }
            open.swap(next);
        }
        done.insert(done.end(), open.begin(), open.end());
        return done;
    }

    void run(const Task& t, Output& out) const {
        if (t.a == t.b)
            self(t.a, out);
        else
            pair(t.a, t.b, out);
    }

    /// Pairs of slot s with every slot of the tree whose box overlaps.
    void query(int s, Output& out) const {
        const float* box = bvh_.box(s);
        int32_t stack[128];
        int top = 0;
        stack[top++] = 0;
        while (top > 0) {
            const BvhNode& nd = bvh_.node(stack[--top]);
            ++out.stats.node_pairs;
            if (!boxes_overlap(box, box + 3, nd.lo, nd.hi)) continue;
            if (nd.leaf()) {
                for (int t = nd.begin; t < nd.end; ++t)
                    if (t != s) test_slots(s, t, out);
            } else if (top + 2 <= 128) {
                stack[top++] = nd.first;
                stack[top++] = nd.first + 1;
            }
        }
    }

private:
    const TriangleBvh& bvh_;
    const float* p_;
    bool cull_;
    const PatchOutlines* outlines_;
    bool only_dirty_;
};

void finish(std::vector<TrianglePair>& pairs) {
    std::sort(pairs.begin(), pairs.end());
    pairs.erase(std::unique(pairs.begin(), pairs.end()), pairs.end());
}

}  // namespace

void CpuCollisionBackend::set_triangles(const MeshTopology& mesh, const std::vector<int32_t>& triangles,
                                        const float* positions) {
    bvh_.build(mesh, triangles, positions, options_.leaf_size, options_.normal_cone_culling);
    if (options_.normal_cone_culling && options_.outline_check) outlines_.build(bvh_);
}

namespace {

void run(const Traversal& trav, bool parallel, std::vector<TrianglePair>& out, CollisionStats& stats) {
    if (!parallel) {
        Output o;
        trav.self(0, o);
        out = std::move(o.pairs);
        stats = o.stats;
    } else {
        const std::vector<Task> tasks = trav.tasks(64);
        tbb::enumerable_thread_specific<Output> local;
        tbb::parallel_for(size_t(0), tasks.size(), [&](size_t i) { trav.run(tasks[i], local.local()); });
        for (Output& o : local) {
            out.insert(out.end(), o.pairs.begin(), o.pairs.end());
            stats.node_pairs += o.stats.node_pairs;
            stats.triangle_tests += o.stats.triangle_tests;
        }
    }
    finish(out);
    stats.pairs = static_cast<int64_t>(out.size());
}

}  // namespace

void CpuCollisionBackend::find_pairs(const float* positions, std::vector<TrianglePair>& out) {
    out.clear();
    stats_ = CollisionStats{};
    if (bvh_.empty()) return;
    bvh_.refit(positions);
    run(Traversal(bvh_, positions, options_.normal_cone_culling, outlines()), options_.parallel, out, stats_);
}

void CpuCollisionBackend::find_pairs_touching(const float* positions, const std::vector<int32_t>& changed,
                                              std::vector<TrianglePair>& out) {
    out.clear();
    stats_ = CollisionStats{};
    if (bvh_.empty()) return;
    slots_.clear();
    for (int32_t t : changed) {
        const int32_t s = bvh_.slot_of(t);
        if (s >= 0) slots_.push_back(s);
    }
    std::sort(slots_.begin(), slots_.end());
    slots_.erase(std::unique(slots_.begin(), slots_.end()), slots_.end());
    if (slots_.empty()) return;
    // Refit what moved and traverse only there: every pair that intersects now and did not
    // before has a moved triangle, so it lies below a dirty node.
    bvh_.refit_slots(positions, slots_);
    std::vector<TrianglePair> found;
    run(Traversal(bvh_, positions, options_.normal_cone_culling, outlines(), true), options_.parallel, found, stats_);
    // Keep the pairs with a changed triangle (a dirty leaf may also hold unchanged ones).
    std::vector<uint8_t>& flag = changed_flag_;
    flag.assign(bvh_.size(), 0);
    for (int32_t s : slots_) flag[s] = 1;
    for (const TrianglePair& p : found)
        if (flag[bvh_.slot_of(p.a)] || flag[bvh_.slot_of(p.b)]) out.push_back(p);
    stats_.pairs = static_cast<int64_t>(out.size());
}

std::unique_ptr<CollisionBackend> make_cpu_collision_backend(CpuCollisionOptions options) {
    return std::make_unique<CpuCollisionBackend>(options);
}

void brute_force_pairs(const MeshTopology& mesh, const std::vector<int32_t>& triangles, const float* p,
                       std::vector<TrianglePair>& out) {
    out.clear();
    const size_t n = triangles.size();
    std::vector<float> box(6 * n);
    for (size_t i = 0; i < n; ++i) {
        const int32_t* v = mesh.triangle(triangles[i]);
        for (int k = 0; k < 3; ++k) {
            box[6 * i + k] = std::min({p[3 * v[0] + k], p[3 * v[1] + k], p[3 * v[2] + k]});
            box[6 * i + 3 + k] = std::max({p[3 * v[0] + k], p[3 * v[1] + k], p[3 * v[2] + k]});
        }
    }
    for (size_t i = 0; i < n; ++i)
        for (size_t j = i + 1; j < n; ++j) {
            const int32_t* a = mesh.triangle(triangles[i]);
            const int32_t* b = mesh.triangle(triangles[j]);
            if (share_vertex(a, b) || !boxes_overlap(&box[6 * i], &box[6 * i + 3], &box[6 * j], &box[6 * j + 3]))
                continue;
            if (triangles_intersect(p + 3 * static_cast<size_t>(a[0]), p + 3 * static_cast<size_t>(a[1]),
                                    p + 3 * static_cast<size_t>(a[2]), p + 3 * static_cast<size_t>(b[0]),
                                    p + 3 * static_cast<size_t>(b[1]), p + 3 * static_cast<size_t>(b[2])))
                out.push_back({std::min(triangles[i], triangles[j]), std::max(triangles[i], triangles[j])});
        }
    std::sort(out.begin(), out.end());
}

}  // namespace sd::anatomy
