// The mesh's volume near each limb joint (issue 14: "the volume control: mesh volume of limbs
// and torso, not only the sweep integral").
//
// The controller (Sect. 4.4) holds each sweep's integral. The mesh near a joint is not the
// sweep: skin shared with the torso blends two sweeps' frames, and a fold's skin leaves its
// cross-section, so a bent hip loses mesh volume the integral does not see (MakeHuman's hip at
// 90°: 0.5 L of the body, 2 % of the hip). Sect. 4.4 assumes the displacement volume constant;
// it is not at a bend.
//
// So once, on the bound mesh, each limb joint is bent alone through a grid of swings, and the
// change of the whole mesh's volume is measured with the controller at work. Each frame then
// grows the limb sweep's keys at the joint by what that table says the mesh loses at the
// joint's present swing, scaled by how much of the growth reaches the mesh.
#pragma once

#include "math/math_types.h"
#include "rig/skeleton.h"
#include "rig/volume.h"

#include <cstdint>
#include <vector>

namespace sd {

class Deformer;

/// What one joint's swing costs the mesh, and how much volume to grow at the joint's keys.
struct JointVolumeTable {
    static constexpr int kSwings = 3;      ///< bends of 45°, 90° and 135°
    static constexpr int kDirections = 8;  ///< every 45° about the rest axis

    int sweep = -1, key = -1;                       ///< the limb's sweep and the joint's key in it
    int parent = -1, child = -1;                    ///< the joint's upper and lower bones
    dvec3 axis{0, 0, 1}, e1{1, 0, 0}, e2{0, 1, 0};  ///< the lower link's rest direction, and two normals
    /// Volume the mesh loses, over the share of a growth at the joint's keys that reaches it:
    /// what to grow there, [swing][direction]; 0 at no bend, held beyond 135°. Negative where
    /// the mesh gains: read between samples as is, then nothing is taken away (see
    /// added_volume).
    std::vector<double> added;
    double most_added = 0.0;  ///< the reading's upper bound

    /// The keys that take the added volume: the joint's key and its neighbours (of `key_count`).
    VolumeControlKeys keys(int key_count) const;
    /// The lower link's rest direction `axis` carried by the lower bone's turn relative to the
    /// upper one in `pose`.
    dvec3 swung_axis(const SkeletonPose& pose) const;
    /// The swing that carries `axis` to `swung` (swung_axis of a pose): bend angle and its
    /// direction about the axis.
    void swing(const dvec3& swung, double* bend, double* direction) const;
    /// The table read at the joint's swing in `pose` (linear in the bend, a trigonometric
    /// polynomial around the axis), within [0, most_added]: a gain is left alone (a fold passing
    /// through itself counts twice in a signed volume, and shrinking a limb to make up for it
    /// would thin it). Given `lowering` (an arm's shoulder: the body's down, KeyMotion::lowering),
    /// nothing is added once the swing lowers the limb towards it by kLoweredWithoutGrowth or
    /// more, fading from the whole reading at no lowering.
    double added_volume(const SkeletonPose& pose, const dvec3& lowering = dvec3(0.0)) const;
};

/// How far a swing lowers an arm (the change of the link's unit direction along the body's down)
/// before its shoulder's table adds nothing. What a lowered arm's mesh loses is the armpit
/// closing, the arm pressed to the chest; grown back into the arm's keys it swelled the top of
/// the shoulder and pressed the armpit's skin into itself (shoulder_abd_20, arm lowered 25°:
/// MakeHuman 5 -> 1 intersecting pairs without it, its 2.9K level of detail 4 -> 0, CesiumMan's
/// skin-to-bone ratio 1.29 -> 1.23; docs/quality.md, twenty-fourth session).
constexpr double kLoweredWithoutGrowth = 0.1;

/// Signed volume of the triangles' cones from `apex` (positions #V*3). Over a closed surface it
/// is the enclosed volume; over a patch whose border stays put or turns about the apex, its
/// change is the volume the patch's motion adds.
double cone_volume(const float* positions, const std::vector<int32_t>& triangles, const dvec3& apex);

/// Bends each limb joint of the deformer's rig (keys with a joint, sweeps that are not thick
/// chains) alone and measures the whole mesh (triangles #T*3, indices into the bound
/// vertices). Leaves the deformer's settings as they were. @throws InvalidInput on bad triangles.
std::vector<JointVolumeTable> measure_joint_volumes(Deformer& deformer, int32_t triangle_count,
                                                    const int32_t* triangles);

}  // namespace sd
