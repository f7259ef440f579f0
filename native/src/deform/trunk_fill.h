// A bent trunk's volume given back to its skin as a fill (issue 14).
//
// A trunk bends about its spine, which lies near the back, so its sweep loses the volume of a
// wedge inside the bend however its sections move, while the skin keeps its distance from the
// spine to within a few per cent (MakeHuman bent 45 degrees: 0.96-1.02 of it, region volume
// -9.3 %). Growing the sweep's sections to put that volume back moved the whole trunk out from
// the spine: its median skin 1.057x its rest distance, the furthest 1.091x (Preserve Volume
// 1.000 and 1.069, losing the 9 %). The fill raises instead the skin the pose left nearest the
// spine, all to one level: every vertex of the trunk at least L times its rest distance from
// the spine, L the lowest level that puts back the volume asked for; skin already further out
// does not move, nor does skin the pose pressed deep into a fold, and at rest, where nothing is
// asked for, nothing does.
#pragma once

#include "bind/bind.h"
#include "rig/rig.h"
#include "rig/skeleton.h"

#include <cstdint>
#include <vector>

namespace sd {

/// The most the skin is raised to: this times its rest distance from the spine (a trunk bent
/// far enough to ask for more gets what this level gives).
constexpr double kHighestFillLevel = 1.5;

/// Skin the pose pressed towards the spine is raised by a share of the fill that falls from
/// all of it at its rest distance to none at (1 - this) of it: a fold inside the bend stays a
/// fold. Raised like the skin beside it, the waist's fold of a trunk bent 60 degrees stood out
/// as a lip (docs/quality.md, twenty-fifth session).
constexpr double kPressedIntoFold = 0.25;

/// How far the fill raises skin at rest distance `rest` from the spine, now at `posed`, at level
/// L >= 1: up to L rest, by at most (L - 1) rest times the share pressed skin keeps.
double fill_raise(double rest, double posed, double level);

/// A vertex of a trunk's skin in a pose, as the fill sees it.
struct FillVertex {
    double rest = 0.0, posed = 0.0;  ///< its distance from the spine at rest and now
    double weight = 0.0;             ///< its weight on the trunk's sweep (the share of the raise it takes)
    double area = 0.0;               ///< the mesh's area about it facing away from the spine, now
};

/// The lowest level L in [1, kHighestFillLevel] whose raises put back `asked` (the sum of area
/// x weight x fill_raise over the skin), or kHighestFillLevel where none does. Exact: that sum
/// is piecewise linear in L.
double fill_level(const std::vector<FillVertex>& skin, double asked);

class TrunkFill {
public:
    /// No trunk is filled.
    TrunkFill() = default;
    /// The skin of every thick chain of `rig` (Sweep::bends_smoothly) in `binding`: each vertex
    /// with weight on the chain's sweep, and its rest distance from the chain's spine (joint to
    /// joint along the bones its keys ride).
    /// @param triangles  #T*3 vertex indices of the bound mesh
    /// @throws InvalidInput on an index outside the binding's vertices
    TrunkFill(const Rig& rig, const Binding& binding, const std::vector<int32_t>& triangles);

    bool empty() const { return chains_.empty(); }
    /// Whether sweep `sweep` is a chain this fill gives volume to.
    bool fills(int sweep) const;

    /// Adds to `out` (#V*3, the bound vertices in this pose) each chain's fill, need[sweep] > 0
    /// being the volume (units^3) to put back at that sweep's skin. Returns each chain's level
    /// (in the order of the rig's sweeps; 1 where nothing was asked for).
    std::vector<double> apply(const SkeletonPose& pose, const std::vector<double>& need, float* out) const;
    /// The same at the levels another mesh's fill reached (its apply's result; a mesh bound
    /// through that mesh's map follows its fill): needs no triangles.
    void apply_levels(const SkeletonPose& pose, const std::vector<double>& levels, float* out) const;

    /// The vertices of the bound mesh this fill reads (the chains' skin and their triangles'
    /// corners), ascending, and the triangles among them: what a copy needs of the mesh.
    std::vector<int32_t> vertices_read() const;
    std::vector<int32_t> triangles_read() const;

private:
    struct Chain {
        int sweep = -1;
        std::vector<dvec3> joints;       ///< its spine at rest: a polyline, joint to joint
        std::vector<int> joint_bones;    ///< the bone that carries each joint
        std::vector<int32_t> vertex;     ///< its skin
        std::vector<double> weight;      ///< each vertex's weight on the chain's sweep
        std::vector<double> rest;        ///< each vertex's rest distance from the spine
        std::vector<int32_t> triangles;  ///< the mesh's triangles about its skin (3 indices each)
        std::vector<int32_t> corners;    ///< their corners as indices into `vertex`, -1 elsewhere
        double facing = 1.0;             ///< -1 for a mesh wound inside out
    };
    static std::vector<FillVertex> posed_skin(const Chain& c, const SkeletonPose& pose, const float* out,
                                              std::vector<dvec3>& away);
    static void raise(const Chain& c, const std::vector<FillVertex>& skin, const std::vector<dvec3>& away, double level,
                      float* out);

    std::vector<Chain> chains_;
};

}  // namespace sd
