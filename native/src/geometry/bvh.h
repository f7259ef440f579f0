// A compact bounding volume hierarchy over triangles of a mesh whose connectivity is fixed
// and whose vertices move: built once (median splits on the rest pose), refitted every frame
// bottom-up. Optionally it also keeps, per node, a normal cone (an axis and the cosine of a
// half-angle that bounds every triangle normal below the node) and whether the node's
// triangles form one edge-connected patch — the two facts that let a self-collision query
// skip a patch that cannot fold onto itself (Volino and Magnenat-Thalmann 1994; with the
// outline condition of patch_outline.h).
//
// Layout: nodes in one array, a node's two children adjacent (left = first, right =
// first + 1) and after their parent, so a reverse sweep over the array refits bottom-up.
// The triangles are stored in leaf order ("slots"); a node covers the slots [begin, end).
#pragma once

#include "geometry/mesh_topology.h"

#include <cstdint>
#include <vector>

namespace sd::anatomy {

struct BvhNode {
    float lo[3], hi[3];
    int32_t first = 0;           ///< inner node: left child (right = first + 1); leaf: first slot
    int32_t count = 0;           ///< leaf: number of triangles (> 0); inner node: 0
    int32_t begin = 0, end = 0;  ///< the slots below this node
    bool leaf() const { return count > 0; }
};

/// A node's normal cone: every normal n below it has n . axis >= cos_half_angle.
/// cos_half_angle = -2 marks "no bound" (a degenerate triangle, or normals all around).
struct NormalCone {
    float axis[3];
    float cos_half_angle;
};

class TriangleBvh {
public:
    /// @param triangles  ids into mesh.triangles of the triangles to hold (any subset)
    /// @param with_cones also maintain normal cones and the connectivity flags
    void build(const MeshTopology& mesh, const std::vector<int32_t>& triangles, const float* positions,
               int leaf_size = 4, bool with_cones = false);

    /// Recomputes every box (and cone) from `positions`.
    void refit(const float* positions);
    /// Recomputes only the leaves holding `slots` and their ancestors, and marks exactly those
    /// nodes dirty (until the next refit).
    void refit_slots(const float* positions, const std::vector<int32_t>& slots);
    bool dirty(int node) const { return dirty_flag_[node] != 0; }

    bool empty() const { return nodes_.empty(); }
    int size() const { return static_cast<int>(slot_triangle_.size()); }
    const std::vector<BvhNode>& nodes() const { return nodes_; }
    const BvhNode& node(int i) const { return nodes_[i]; }
    bool with_cones() const { return with_cones_; }
    const NormalCone& cone(int node) const { return cones_[node]; }
    bool connected(int node) const { return connected_[node] != 0; }
    /// True when a and b are the two children of one node.
    bool siblings(int a, int b) const { return a != b && a > 0 && b > 0 && parent_[a] == parent_[b]; }
    /// True when nodes a and b (disjoint) share a triangle edge (with_cones trees only).
    bool adjacent(int a, int b) const;
    /// The bound of the union of two nodes' normal cones (cos_half_angle -2: none).
    NormalCone merged_cone(int a, int b) const;

    /// Per slot: the triangle id, its three vertices, its box (lo xyz, hi xyz).
    int32_t triangle(int slot) const { return slot_triangle_[slot]; }
    const int32_t* vertices(int slot) const { return &slot_vertices_[3 * static_cast<size_t>(slot)]; }
    const float* box(int slot) const { return &slot_box_[6 * static_cast<size_t>(slot)]; }
    /// The slot of a triangle id, or -1 when the tree does not hold it.
    int32_t slot_of(int32_t triangle) const {
        return triangle >= 0 && triangle < static_cast<int32_t>(slot_of_triangle_.size()) ? slot_of_triangle_[triangle]
                                                                                          : -1;
    }

    /// Nearest hit of the ray o + t d, 0 <= t <= t_max, with a held triangle (Möller–Trumbore
    /// in double), or the farthest one. @return false when there is none; else *t and
    /// *triangle (an id).
    bool ray_first_hit(const float* positions, const double* o, const double* d, double t_max, double* t,
                       int32_t* triangle, bool farthest = false) const;

private:
    void refit_leaf(const float* positions, int node);
    void refit_inner(int node);
    void compute_slot(const float* positions, int slot);

    std::vector<BvhNode> nodes_;
    std::vector<int32_t> parent_;
    std::vector<int32_t> slot_triangle_, slot_vertices_, leaf_of_slot_, slot_of_triangle_;
    std::vector<float> slot_box_, slot_normal_;
    bool with_cones_ = false;
    std::vector<NormalCone> cones_;
    std::vector<uint8_t> connected_;
    std::vector<uint32_t> border_offsets_;  // per node: CSR rows of border_slots_
    std::vector<int32_t> border_slots_;     // sorted slots outside the node sharing an edge with it
    std::vector<int32_t> dirty_;
    std::vector<uint8_t> dirty_flag_;
    std::vector<int32_t> descendants_end_;            // per node: its descendants are [first, end)
    std::vector<int32_t> subtree_roots_, top_nodes_;  // the cut for the parallel refit
};

}  // namespace sd::anatomy
