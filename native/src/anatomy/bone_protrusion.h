// Bone protrusion (Sect. 4.3): "The penetration depth of each skin vertex in the collision
// region is computed by shooting a ray to the triangles of the bone in the collision region.
// The vertex is then pulled back to the exterior of the protruding bone."
//
// A bone proxy is a closed triangle mesh, star-shaped about an interior point (its center),
// that rides on a joint: with the lower link (fraction 1, the olecranon on the ulna) or part
// of the way (fraction 0.5 follows the bisector, as the patella gliding over the femur
// does). Per frame the skin vertices near it are taken into the proxy's rest frame; a vertex
// inside is pushed along the ray from the center through it to where that ray leaves the
// proxy (the ray cast against the proxy's triangles, in a small BVH); the neighbouring skin
// follows with a smooth falloff (falloff.h).
//
// Automatic proxies are ellipsoids sized from the joint's key ellipse: the olecranon behind
// the elbow, the patella in front of the knee, each placed just under the rest skin on the
// joint's extensor side (opposite its flexion direction) and shrunk until no rest vertex is
// inside, so the rest pose is untouched. As the joint flexes they come out of the soft
// tissue that covers them in extension (the olecranon leaves its fossa, the patella rides
// onto the femoral condyles): the proxy moves out along the extensor side by an amount that
// grows smoothly with flexion.
#pragma once

#include "geometry/bvh.h"
#include "anatomy/falloff.h"
#include "geometry/mesh_topology.h"
#include "math/math_types.h"

#include <string>
#include <vector>

namespace sd::anatomy {

/// A closed triangle mesh in the armature's rest space.
struct ProxyShape {
    std::vector<float> positions;    ///< #N*3
    std::vector<int32_t> triangles;  ///< #F*3, outward (counter-clockwise seen from outside)
};

/// An ellipsoid (icosphere with `subdivisions` levels: 2 -> 320 triangles) with orthonormal
/// `axes` (columns) and half-lengths `semi`.
ProxyShape ellipsoid_shape(const dvec3& center, const dmat3& axes, const dvec3& semi, int subdivisions = 2);

class BoneProxy {
public:
    /// @param fraction  share of the joint's rotation the proxy follows (1 = the lower link)
    /// @throws InvalidInput unless the mesh is closed (every edge in exactly two triangles,
    ///         consistently oriented) and star-shaped about its volume centroid (every
    ///         triangle's plane has the centroid strictly behind it). Inward-oriented meshes
    ///         are turned outward.
    BoneProxy(int joint, double fraction, ProxyShape shape, std::string name);

    int joint() const { return joint_; }
    double fraction() const { return fraction_; }
    const std::string& name() const { return name_; }
    const dvec3& center() const { return center_; }
    double bound() const { return bound_; }
    const ProxyShape& shape() const { return shape_; }

    /// How far (rest frame) the proxy moves out at full flexion, and the flexion beyond rest
    /// (radians) at which it is fully out; zero by default (a rigid proxy).
    void set_emergence(const dvec3& offset, double full_flexion) {
        emergence_ = offset;
        emergence_full_ = full_flexion;
    }
    const dvec3& emergence() const { return emergence_; }
    double emergence_full_flexion() const { return emergence_full_; }

    /// The point (rest frame) the bone grows from, the joint: the proxy counts as solid all
    /// the way from it, so a vertex between it and the proxy is pushed out too (when the
    /// proxy comes out of the flesh in flexion, the skin cannot stay under it).
    void set_anchor(const dvec3& anchor);
    const dvec3& anchor() const { return anchor_; }

    /// Skin vertices the proxy may reach (chosen by the caller at rest).
    void set_candidates(std::vector<int32_t> vertices) { candidates_ = std::move(vertices); }
    const std::vector<int32_t>& candidates() const { return candidates_; }

    /// Distance from the center to the surface along unit direction `dir` (rest frame).
    double surface_distance(const dvec3& dir) const;
    /// True when the rest-frame point x is strictly inside.
    bool contains(const dvec3& x) const;

    /// For every candidate inside the proxy posed by `transform` — on the ray from the anchor
    /// through it, nearer the anchor than where the ray last leaves the proxy — the
    /// displacement (world space) that brings it there, times `strength`. Appends to
    /// sources/deltas.
    /// @return the largest displacement length
    double push(const dmat4& transform, const float* positions, double strength, std::vector<int32_t>& sources,
                std::vector<dvec3>& deltas) const;

private:
    int joint_;
    double fraction_;
    std::string name_;
    ProxyShape shape_;
    MeshTopology mesh_;
    TriangleBvh bvh_;
    dvec3 center_{0.0};
    double bound_ = 0.0;  ///< largest distance from the center to a proxy vertex
    dvec3 emergence_{0.0};
    dvec3 anchor_{0.0};
    double anchor_bound_ = 0.0;  ///< largest distance from the anchor to a proxy vertex
    double emergence_full_ = 1.0;
    std::vector<int32_t> candidates_;
};

}  // namespace sd::anatomy
