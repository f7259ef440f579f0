// Self-intersection of the skin near joints: which pairs of triangles of a set (the joint
// regions) intersect, skipping pairs that share a vertex (neighbours touch by construction).
//
// The query sits behind an abstract CollisionBackend, so that a GPU implementation (the
// paper used CULLIDE on the GPU) can replace the CPU one without touching the folding code.
// The CPU backend refits a TriangleBvh every frame and runs a BVH-against-itself traversal;
// with normal-cone culling it skips every patch that is a disk whose normals all lie within
// 90 degrees of one axis and whose outline, projected along that axis, does not cross itself
// (such a patch cannot meet itself; Volino and Magnenat-Thalmann 1994; patch_outline.h). The
// narrow phase is the exact triangle–triangle test. Without the outline's test
// (outline_check off) the culling is four times cheaper and can miss pairs (a ramp whose
// normals point up while its last turn passes through its first).
#pragma once

#include "geometry/bvh.h"
#include "geometry/patch_outline.h"
#include "geometry/mesh_topology.h"

#include <cstdint>
#include <memory>
#include <vector>

namespace sd::anatomy {

struct TrianglePair {
    int32_t a, b;  ///< triangle ids, a < b
    bool operator<(const TrianglePair& o) const { return a < o.a || (a == o.a && b < o.b); }
    bool operator==(const TrianglePair& o) const { return a == o.a && b == o.b; }
};

struct CollisionStats {
    int64_t node_pairs = 0;      ///< box-box tests
    int64_t triangle_tests = 0;  ///< exact triangle-triangle tests run
    int64_t pairs = 0;           ///< intersecting pairs reported
};

class CollisionBackend {
public:
    virtual ~CollisionBackend() = default;
    virtual const char* name() const = 0;
    /// The triangles (ids into mesh.triangles) to test against each other; called when the
    /// set changes, not every frame. The mesh must outlive the backend's use of it.
    virtual void set_triangles(const MeshTopology& mesh, const std::vector<int32_t>& triangles,
                               const float* positions) = 0;
    virtual int triangle_count() const = 0;
    /// Every pair of the set that intersects and shares no vertex, sorted (a < b).
    virtual void find_pairs(const float* positions, std::vector<TrianglePair>& out) = 0;
    /// After `positions` changed at vertices of the triangles `changed` only (ids; ids not in
    /// the set are ignored): every intersecting pair with at least one triangle in `changed`.
    virtual void find_pairs_touching(const float* positions, const std::vector<int32_t>& changed,
                                     std::vector<TrianglePair>& out) = 0;
    virtual CollisionStats last_stats() const = 0;
};

struct CpuCollisionOptions {
    bool normal_cone_culling = true;
    int leaf_size = 8;
    bool parallel = true;
    /// With normal_cone_culling: cull only disks whose projected outline does not cross
    /// itself (exact: every pair is found). Off: every connected patch within the cone is
    /// culled, which can miss pairs.
    bool outline_check = true;
};

class CpuCollisionBackend final : public CollisionBackend {
public:
    explicit CpuCollisionBackend(CpuCollisionOptions options = {}) : options_(options) {}
    const char* name() const override { return "cpu-bvh"; }
    void set_triangles(const MeshTopology& mesh, const std::vector<int32_t>& triangles,
                       const float* positions) override;
    int triangle_count() const override { return bvh_.size(); }
    void find_pairs(const float* positions, std::vector<TrianglePair>& out) override;
    void find_pairs_touching(const float* positions, const std::vector<int32_t>& changed,
                             std::vector<TrianglePair>& out) override;
    CollisionStats last_stats() const override { return stats_; }
    const TriangleBvh& bvh() const { return bvh_; }

private:
    const PatchOutlines* outlines() const {
        return options_.normal_cone_culling && options_.outline_check ? &outlines_ : nullptr;
    }

    CpuCollisionOptions options_;
    TriangleBvh bvh_;
    PatchOutlines outlines_;
    CollisionStats stats_;
    std::vector<int32_t> slots_;
    std::vector<uint8_t> changed_flag_;
};

std::unique_ptr<CollisionBackend> make_cpu_collision_backend(CpuCollisionOptions options = {});

/// The reference: every pair of `triangles` tested (after a box check), O(n^2). Sorted.
void brute_force_pairs(const MeshTopology& mesh, const std::vector<int32_t>& triangles, const float* positions,
                       std::vector<TrianglePair>& out);

}  // namespace sd::anatomy
