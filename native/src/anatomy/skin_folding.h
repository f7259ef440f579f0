// Skin folding (Sect. 4.3): "Once all triangles in the region of self-intersection have been
// detected, we construct a bisecting plane for the self-intersection by fitting a plane
// (using least squares) to their vertices. The distance from this plane to each vertex gives
// the penetration depth of the vertex. By pulling the vertices back to the bisecting plane,
// we can generate skin-folding effects."
//
// Per intersection region (a connected set of intersecting triangles, joined by the
// intersecting pairs and by shared vertices):
//  1. the two sheets: the parts (skin_parts.h) of the triangles of the region's pairs —
//     forearm against upper arm, arm against chest, thigh against thigh; the most frequent
//     pair of different parts gives sides A and B, other parts join the side opposite the
//     part they collide with. A region whose pairs all lie within one part (skin folding
//     onto itself inside one link, or crumpling where two sweeps blend) is either handed
//     back to the caller (`single_part`, to be relaxed) or takes its sides from the vertex
//     normals: the layers face each other, the plane's normal is the normals' principal
//     axis, and skin whose outside faces +n belongs on the - side;
//  2. the bisecting plane: total least squares through the vertices of the region's
//     triangles, its normal oriented from side A to side B by the posed bones of the parts;
//  3. penetrating vertices: from the region's vertices on the wrong side of the plane, a flood
//     over the mesh through same-side vertices still on the wrong side (a limb pressed deep
//     into another has penetrating skin far from the intersection curve), within a sphere
//     around the region;
//  4. each is pulled back to the plane, a margin short of it on its own side, and the
//     displacement fades into the neighbouring skin of the same side (falloff.h).
// The caller re-detects and repeats until no pair remains, relaxing what the planes leave
// (anatomy.cpp).
#pragma once

#include "anatomy/falloff.h"
#include "geometry/mesh_topology.h"
#include "geometry/self_intersection.h"
#include "anatomy/skin_parts.h"

#include <cstdint>
#include <vector>

namespace sd::anatomy {

struct FoldingParams {
    double margin = 0.0;          ///< gap kept on each side of the bisecting plane
    double falloff_radius = 0.0;  ///< geodesic radius of the smooth falloff
    bool planes = true;           ///< false: hand every region back to be relaxed
    /// The limb's scale at the joint (its key ellipse's larger half-axis), 0 = unknown: skin
    /// farther than 2.5 of it from the region's centre, or more than 1 of it on the wrong side
    /// of the plane, is taken to be no part of the contact (a plane can only describe a
    /// contact locally).
    double limb_radius = 0.0;
};

struct FoldingStats {
    int regions = 0;
    int pulled = 0;               ///< vertices pulled back to a plane
    int falloff = 0;              ///< neighbours moved by the falloff
    int single_part_regions = 0;  ///< regions whose sides came from normals
    double max_depth = 0.0;       ///< deepest penetration pulled back
};

class SkinFolding {
public:
    /// @param part_reference   #B posed reference point of each bone (its midpoint)
    /// @param triangle_joint   #T joint owning each triangle's region, or -1
    /// @param params           per joint
    FoldingStats fold(const MeshTopology& mesh, const SkinParts& parts, const std::vector<TrianglePair>& pairs,
                      const std::vector<dvec3>& part_reference, const std::vector<int32_t>& triangle_joint,
                      const std::vector<FoldingParams>& params, float* positions, VertexEdits& edits, Falloff& falloff,
                      std::vector<int32_t>* moved = nullptr, std::vector<TrianglePair>* single_part = nullptr);

    /// Untangles what plane folding left, and skin crumpled within one part: `passes` Jacobi
    /// passes of uniform Laplacian smoothing (step 0.5) over the vertices of the pairs'
    /// triangles and the skin within `radius` (rest path length) of them.
    /// @return the number of vertices moved
    /// Vertices on no sweep (bone-driven: head, hands, feet) are left alone.
    int relax(const MeshTopology& mesh, const SkinParts& parts, const std::vector<TrianglePair>& pairs, double radius,
              int passes, float* positions, VertexEdits& edits, const std::vector<int32_t>& triangle_joint,
              std::vector<int32_t>* moved = nullptr);

private:
    std::vector<int32_t> local_of_triangle_, vertex_mark_, vertex_side_;
    std::vector<uint8_t> label_mask_;
    int stamp_ = 0;  // vertex_mark_ values of the current region (never reused)
};

}  // namespace sd::anatomy
