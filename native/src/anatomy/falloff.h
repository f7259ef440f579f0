// Moving skin vertices with a smooth falloff into the neighbouring skin, and remembering
// where every moved vertex was before the anatomical effects of this frame (for the volume
// change I_C and for the stage statistics).
//
// The falloff runs over the mesh graph with rest edge lengths (a geodesic distance that does
// not change with the pose): every vertex within `radius` of a moved ("source") vertex gets
// w(d / radius) times the displacement of its nearest source, w(s) = (1 - s^2)^2, which is 1
// with zero slope at the source and 0 with zero slope at the radius.
#pragma once

#include "geometry/mesh_topology.h"
#include "math/math_types.h"

#include <cstdint>
#include <vector>

namespace sd::anatomy {

/// The vertices moved during one frame and their positions before the first move.
class VertexEdits {
public:
    void reset(int vertex_count);
    /// Call before changing vertex v; `owner` is the joint responsible (first one kept).
    void touch(int v, const float* positions, int owner) {
        if (flag_[v]) return;
        flag_[v] = 1;
        list_.push_back(v);
        owner_[v] = owner;
        for (int k = 0; k < 3; ++k) before_[3 * static_cast<size_t>(v) + k] = positions[3 * static_cast<size_t>(v) + k];
    }
    bool moved(int v) const { return flag_[v] != 0; }
    int owner(int v) const { return owner_[v]; }
    const float* before(int v) const { return &before_[3 * static_cast<size_t>(v)]; }
    const std::vector<int32_t>& list() const { return list_; }
    /// Clears the record of the vertices moved so far (positions are not changed).
    void clear();

private:
    std::vector<uint8_t> flag_;
    std::vector<int32_t> list_, owner_;
    std::vector<float> before_;
};

/// Applies displacements with a geodesic falloff. Scratch arrays are kept between calls.
class Falloff {
public:
    void reset(int vertex_count);
    /// positions[s] += delta[i] for every source s = sources[i]; every other vertex v within
    /// `radius` gets w(d/radius) times the delta of its nearest source, where the path runs
    /// only through allowed vertices: all when labels == nullptr, else those whose label l
    /// has l >= 0 and label_allowed[l] != 0. Moved vertices are recorded in `edits` (and
    /// appended to `moved` when given).
    /// @return the number of falloff (non-source) vertices moved
    int apply(const MeshTopology& mesh, const std::vector<int32_t>& sources, const std::vector<dvec3>& deltas,
              double radius, const int32_t* labels, const uint8_t* label_allowed, float* positions, VertexEdits& edits,
              int owner, std::vector<int32_t>* moved = nullptr);

private:
    std::vector<float> dist_;
    std::vector<int32_t> nearest_, touched_;
};

}  // namespace sd::anatomy
