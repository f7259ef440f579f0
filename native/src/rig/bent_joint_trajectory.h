// A limb's trajectory at a bent joint: the paper's cubic, its tangent at the joint key
// shortened while the joint bends up to a right angle.
//
// The paper's C2 cubic passes through the joint key's centre, on the joint, with the
// bisector as its tangent, so it comes into the corner from its outside: a cubic Hermite span
// from the last upper-arm key to the elbow with those tangents bulges outwards by
// 0.148 sin(bend / 2) times the span's length (the 4.7K character's elbow at 90 degrees:
// 10 mm, 35 mm before the joint, the skin on the back of its upper arm 1.16x its rest
// distance from the bone; Preserve Volume 1.11). A shorter tangent there keeps the trajectory
// on the bones up to nearer the joint (0.8 sin^2(since / 2) of it taken off: 0.4 at a right
// angle from a straight rest; that elbow's skin 1.16 -> 1.10, the knee's 1.12 -> 1.07).
//
// The sections' planes turn between the keys as before, so a shorter tangent makes the
// inside of the joint turn in a shorter stretch. Two places where that folds the skin into
// itself keep the paper's cubic:
//  - past a right angle (the eighteenth session, the cut at every bend: elbows at 120-150
//    degrees passed through themselves more, 65 -> 70 pairs on the 13K MakeHuman male): the
//    cut fades out between 90 and 120 degrees of the joint's bend;
//  - a joint thick for its keys' spacing (the joint key's larger half-axis times the bend
//    over the distance between its neighbours; at 90 degrees CesiumMan's knee 0.51-0.58,
//    MakeHuman's elbow 0.50-0.57, the procedural limbs and MakeHuman's knee 0.34-0.40): with
//    the cut, CesiumMan's knee at 90 degrees passed through itself (0 -> 5 pairs); it fades
//    out between 0.42 and 0.50.
#pragma once

#include "rig/rig.h"

namespace sd {

/// How much of a joint key's tangent is taken off: 0 at rest, beyond 120 degrees of bend and
/// on a thick joint; at most 0.8 sin^2(since / 2). `bend` is the angle between the joint's
/// neighbouring keys' normals now, `since` how far the far one turned since rest as seen
/// from the near one, `fold` the joint's thickness for its spacing (see the file comment).
double bent_joint_tangent_cut(double bend, double since, double fold);

/// Shortens the tangents of `posed` (the posed geometry of sweep `s`) at each interior joint
/// key as above; a thick chain (a torso) keeps the paper's cubic.
void tighten_bent_joints(const Sweep& s, SweepGeometry& posed);

/// The posed geometry of sweep `s` through its posed keys, its trajectory tightened at bent
/// joints: what the deformer gives the skin and sd_rig_evaluate_posed_sweep shows.
SweepGeometry posed_geometry(const Sweep& s, const std::vector<dvec3>& centers, const std::vector<dquat>& rotations);

}  // namespace sd
