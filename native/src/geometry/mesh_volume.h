// Volumes of skin regions: a closed mesh's signed volume, and the volume of an open region
// (a limb's triangles) closed by a fan over each of its boundary loops from the loop's
// centroid, so that a loop that moves rigidly (a wrist ring following the hand) adds the
// same cap volume in every pose.
#pragma once

#include "geometry/mesh_topology.h"

#include <cstdint>
#include <vector>

namespace sd::anatomy {

/// Σ signed tetrahedron volumes of all triangles from the origin (exact for closed meshes).
double mesh_volume(const MeshTopology& mesh, const float* positions);

/// Volume enclosed by `triangles` (ids) plus a fan cap on each boundary loop.
double closed_region_volume(const MeshTopology& mesh, const std::vector<int32_t>& triangles, const float* positions);

/// A region's triangles and its boundary loops (each loop's directed edges a -> b, in order),
/// found once; volume() then costs one pass over the triangles and loops.
class ClosedRegion {
public:
    ClosedRegion() = default;
    ClosedRegion(const MeshTopology& mesh, std::vector<int32_t> triangles);
    /// The same as closed_region_volume, parallel over fixed blocks (the sum does not depend
    /// on the number of threads).
    double volume(const float* positions) const;
    const std::vector<int32_t>& triangles() const { return triangles_; }
    int loop_count() const { return static_cast<int>(loops_.size()); }

private:
    const MeshTopology* mesh_ = nullptr;
    std::vector<int32_t> triangles_;
    std::vector<std::vector<std::pair<int32_t, int32_t>>> loops_;
};

}  // namespace sd::anatomy
