// Cross-sections of the mesh (Sect. 3.2): cut the mesh with a plane, walk the cut into
// polylines, and pick the one loop that surrounds a bone (the arm's loop at the shoulder,
// not the torso's; this thigh's loop, not the other thigh's).
#pragma once

#include "geometry/mesh.h"

#include <vector>

namespace sd::fit {

/// A point of a cut on mesh edge (v0, v1): p = (1 - t) x_v0 + t x_v1.
struct SectionPoint {
    dvec3 p{0.0};
    int32_t v0 = 0, v1 = 0;
    double t = 0.0;
};

/// One connected piece of a cut, in walking order. An open piece ended at a mesh border
/// (a hole, a non-manifold spot); it is treated as closed by the chord between its ends.
struct SectionLoop {
    std::vector<SectionPoint> points;
    bool closed = true;
};

/// Cuts the mesh with the plane through `origin` with unit normal `normal`.
/// Vertices exactly on the plane count as being on its positive side, so every piece
/// crosses edges only. Pieces of fewer than 3 points are dropped.
std::vector<SectionLoop> cut_mesh(const FitMesh& mesh, const dvec3& origin, const dvec3& normal);

/// An orthonormal frame of a plane: u, v in the plane, n its normal, u x v = n.
struct PlaneFrame {
    dvec3 origin{0.0}, u{1, 0, 0}, v{0, 1, 0}, n{0, 0, 1};
    /// u is `reference` projected into the plane (any in-plane direction if parallel to n).
    PlaneFrame(const dvec3& origin, const dvec3& normal, const dvec3& reference);
    dvec2 to_plane(const dvec3& p) const { return dvec2(glm::dot(p - origin, u), glm::dot(p - origin, v)); }
    dvec3 to_space(const dvec2& q) const { return origin + q.x * u + q.y * v; }
};

/// Signed area of a closed polygon (counter-clockwise positive).
double polygon_area(const std::vector<dvec2>& polygon);
/// Area centroid of a closed polygon (the vertex mean for a degenerate one).
dvec2 polygon_centroid(const std::vector<dvec2>& polygon);
/// Whether q is inside the closed polygon (non-zero winding number).
bool polygon_contains(const std::vector<dvec2>& polygon, const dvec2& q);
/// Distance from q to the closed polygon's boundary.
double polygon_distance(const std::vector<dvec2>& polygon, const dvec2& q);

/// Which loop surrounds a point.
struct LoopPick {
    int loop = -1;          ///< -1: none
    bool contains = false;  ///< false: the nearest loop, which does not contain the point
    double distance = 0.0;  ///< from the point to the loop
};

/// Among the polygons that contain q the nearest one (the innermost of nested layers, and
/// never a loop of another body part beside it); if none contains q, the nearest polygon
/// within max_distance.
LoopPick pick_loop(const std::vector<std::vector<dvec2>>& polygons, const dvec2& q, double max_distance);

}  // namespace sd::fit
