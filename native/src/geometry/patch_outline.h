// The outline condition of normal-cone culling. Volino and Magnenat-Thalmann (1994): a patch
// whose normals all lie within 90 degrees of one axis cannot meet itself *if* it is a disk
// whose outline, projected along the axis, does not cross itself. The cone alone is not
// enough: a spiral ramp's normals all point up, yet its last turn can pass through its first.
//
// PatchOutlines keeps, for each node of a TriangleBvh, the node's outline (its edges used by
// one of its triangles) when the node's triangles form a disk, and tests a projected
// outline, a node's or the union of two adjacent nodes', for crossings. A node that is not
// known to be a disk (an edge of the set in three triangles, a vertex whose triangles in the
// set form two fans, a hole, an outline longer than kMaxOutline) has none and is never culled.
#pragma once

#include <cstdint>
#include <vector>

namespace sd::anatomy {

class TriangleBvh;

class PatchOutlines {
public:
    /// Outlines longer than this are not kept (their nodes are tested triangle by triangle
    /// below; the children's outlines are shorter).
    static constexpr int kMaxOutline = 512;

    /// One thread's buffers for the tests.
    struct Scratch {
        std::vector<uint64_t> edges;
        std::vector<double> segments;  // per edge u0 w0 u1 w1
        std::vector<int32_t> order;
        std::vector<double> starts;
    };

    /// @param bvh  its slots and nodes; the topology is fixed, so the outlines are found once, here.
    void build(const TriangleBvh& bvh);

    /// True when `node`'s triangles form a disk whose outline is kept.
    bool is_disk(int node) const { return node >= 0 && node < static_cast<int>(disk_.size()) && disk_[node]; }

    /// True when `node` is a disk and its outline, projected along the unit `axis`, neither
    /// crosses nor touches itself (nearer than a millionth of its extent counts as touching).
    bool projects_simply(int node, const float* axis, const float* positions, Scratch& scratch) const;

    /// The same for the union of two disjoint disk nodes, itself a disk when they share one
    /// chain of edges and no other vertex.
    bool union_projects_simply(int a, int b, const float* axis, const float* positions, Scratch& scratch) const;

    /// The outline of `node` as sorted edge keys (see edge_key), empty when none is kept.
    std::vector<uint64_t> outline(int node) const;

    static uint64_t edge_key(int32_t a, int32_t b) {
        const uint32_t lo = static_cast<uint32_t>(a < b ? a : b), hi = static_cast<uint32_t>(a < b ? b : a);
        return (static_cast<uint64_t>(lo) << 32) | hi;
    }

private:
    std::vector<uint32_t> offsets_;         // per node: CSR rows of edges_ (an empty row: none kept)
    std::vector<uint64_t> edges_;           // outline edges by key, each with its direction (a loop)
    std::vector<uint32_t> vertex_offsets_;  // per node: CSR rows of vertices_
    std::vector<int32_t> vertices_;         // the outline's sorted vertices
    std::vector<uint8_t> disk_;
};

}  // namespace sd::anatomy
