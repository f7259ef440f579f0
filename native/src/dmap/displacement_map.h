// The continuous displacement map d(θ, t) of Sect. 3.4, one smooth surface per sweep.
//
// Binding gives every sweep influence of a rest vertex V its parameters (θ_V, t_V) and its
// local coordinates L_V = R(t_V)^T (V - C(t_V)) = (a_V cos θ_V, b_V sin θ_V, c_V). The map
// approximates the samples
//     d_V = L_V - (a(t_V) cos θ_V, b(t_V) sin θ_V, 0)
// (the paper's displacement from the moving ellipse, keeping the out-of-plane part c_V) by
// one function d(θ, t) per sweep: a bicubic B-spline over a regular control grid, periodic
// in θ and open in t, evaluated with OpenSubdiv (Far::PatchTable + Far::PatchMap over a
// Catmull-Clark control cage shaped like a cylinder: all its faces are regular, so its limit
// surface is exactly the uniform bicubic B-spline of the grid, with smooth boundary rules at
// the two ends). The control points are fitted by weighted least squares (weight = the
// vertex's weight on that sweep) with a small bending term that fills regions without
// samples. t is the sweep's global parameter, uniform per span (span + u) / spans, as in
// sd_rig_evaluate_sweep.
//
// With the map, the rest body is a continuous surface V(θ, t) = S(θ, t) + R(t) d(θ, t), so
// geometry that was never fitted can be bound without re-fitting the rig:
//  * the weights of a new point come from the fitted mesh (closest point, barycentric);
//  * its (θ, t) per sweep from the same plane search as binding (Sect. 3.3);
//  * its local coordinates from the map, L = ellipse(θ, t) + d(θ, t) — the point becomes the
//    body's smooth surface point at its (θ, t), so a subdivided or retopologised mesh or a
//    noisy scan follows the smooth body — where that point lies within a tolerance of the
//    point's own offset ("snap"); elsewhere (folds and caps where d is not single-valued:
//    the crotch under the torso sweep, the armpit) the point keeps its exact offset.
//  * Beyond a sweep's end planes (binding clamps such points to the end ellipse and keeps
//    their distance from the plane as local z) t continues past 0 or 1 by z / |dC/dt|, so the
//    caps of a sweep (shoulder, hip) get their own rows of the map.
// OpenSubdiv is linked only by the separate library libsweepdeform_dmap (see
// abi/dmap.cpp), never by libsweepdeform.
#pragma once

#include "bind/bind.h"
#include "rig/rig.h"

#include <cstdint>
#include <memory>
#include <vector>

namespace sd {

struct DisplacementMapOptions {
    int theta_cells = 24;      ///< control points around a sweep (periodic), 4..256
    int t_cells_per_span = 3;  ///< control intervals along each span, 1..64
    double smoothing = 1e-3;   ///< bending weight relative to the data term, >= 0
};

/// Fit residuals of one sweep's map at its own samples (local units).
struct DisplacementFitStats {
    int samples = 0;
    int rows = 0, columns = 0;    ///< control grid: rows along t, columns around θ
    double rms = 0.0, max = 0.0;  ///< |d_V - d(θ_V, t_V)|, weighted rms and max
};

/// Barycentric closest-point queries on a triangle mesh (a uniform grid of triangles).
class ClosestPoint {
public:
    ClosestPoint() = default;
    ClosestPoint(std::vector<dvec3> positions, std::vector<int32_t> triangles);
    /// Closest point on the mesh to p: its triangle and barycentric coordinates.
    /// @return the distance
    double query(const dvec3& p, int* triangle, dvec3* barycentric) const;
    const std::vector<int32_t>& triangles() const { return triangles_; }

private:
    std::vector<dvec3> positions_;
    std::vector<int32_t> triangles_;
    dvec3 lo_{0.0};
    double cell_ = 1.0;
    int dims_[3] = {1, 1, 1};
    std::vector<uint32_t> cell_start_, cell_items_;  // triangles per grid cell
};

class DisplacementMap {
public:
    /// snap for bind(): every point keeps its own offset / every point takes the map's.
    static constexpr double kExact = 0.0;
    static constexpr double kSurface = 1e300;
    /// The default: points within 10 % of the local half-axis min(a(t), b(t)) of the map's
    /// surface take the map's point (see docs/pipeline.md for the measurements behind it).
    static constexpr double kDefaultSnap = 0.1;

    DisplacementMap();
    ~DisplacementMap();
    DisplacementMap(DisplacementMap&&) noexcept;
    DisplacementMap& operator=(DisplacementMap&&) noexcept;

    /// Fits the map of a bound mesh. @param triangles #T*3 vertex indices of the bound mesh
    /// (carries the weights to new points). @throws InvalidInput
    static DisplacementMap fit(const Rig& rig, const Binding& binding, int triangle_count, const int32_t* triangles,
                               const DisplacementMapOptions& options = {});

    int sweep_count() const;
    const DisplacementFitStats& stats(int sweep) const;
    /// d(θ, t) in the sweep's local frame (t in [0, 1]).
    dvec3 displacement(int sweep, double theta, double t) const;
    /// L(θ, t) = (a(t) cos θ, b(t) sin θ, 0) + d(θ, t) at rest.
    dvec3 local(const Rig& rig, int sweep, double theta, double t) const;
    /// The rest body point C(t) + R(t) L(θ, t), armature space.
    dvec3 rest_point(const Rig& rig, int sweep, double theta, double t) const;

    /// Binds `count` points (#count*3, armature space, rest pose) through the map: weights
    /// from the fitted mesh, parameters by the plane search; a sweep influence takes the map's
    /// local coordinates where they lie within snap x min(a(t), b(t)) of its own, else keeps
    /// its own (kExact: all keep theirs; kSurface: all take the map's). The rig must be the
    /// one the map was fitted with. @param snapped if given, the number of sweep influences
    /// that took the map's coordinates, of all. @throws InvalidInput
    Binding bind(const Rig& rig, int count, const float* positions, double snap = kDefaultSnap, int* snapped = nullptr,
                 int* influences = nullptr) const;

    /// The weights bind() gives the points: per point its sweep and bone influences from the
    /// closest point of the fitted mesh, barycentric, normalised (dense rows, -1 unused).
    void transfer_weights(int count, const float* positions, int* sweep_slots, std::vector<int32_t>& sweep_ids,
                          std::vector<float>& sweep_weights, int* bone_slots, std::vector<int32_t>& bone_ids,
                          std::vector<float>& bone_weights) const;

private:
    struct Impl;
    std::unique_ptr<Impl> impl_;
};

}  // namespace sd
