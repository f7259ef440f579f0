// The maths of one key ellipse's corrections (Sect. 4.2), with no rig or pose: the angle
// between two directions, the correction at a joint angle interpolated from the artist's
// samples, and its application to a placed key. The rig validates corrections with them
// (rig.cpp) and the pose places keys with them (key_pose.cpp); which joint's angle selects a
// key's correction is KeyJoint's business (rig.h).
#pragma once

#include "math/math_types.h"
#include "rig/key_ellipse.h"

#include <vector>

namespace sd {

/// Corrections closer than this (radians) belong to the same angle: setting one there
/// replaces the other, and the interpolation averages them.
constexpr double kCorrectionAngleTolerance = 1e-3;

/// Angle in [0, pi] between two vectors (atan2 of |u x v| and u . v: accurate near 0 and pi).
double angle_between(const dvec3& u, const dvec3& v);

/// The key's correction at joint angle `angle`: the non-muted corrections are samples over
/// the angle (samples closer than kCorrectionAngleTolerance are averaged); unless one of them
/// lies at the rest angle, the rest angle is one more sample with no correction, so the rest
/// pose is untouched. Through the samples runs a monotone cubic Hermite spline per component
/// (centre offset, rotation vector, log of the scales): Fritsch–Carlson slopes inside, zero
/// slope at the first and last sample, constant beyond them. So it never overshoots the
/// samples, is C1, and an angle within 1e-5 rad of a sample gives that sample exactly.
KeyCorrectionValue correction_at(const std::vector<KeyCorrection>& corrections, double rest_angle, double angle);

/// Applies a correction to one placed key: center + R dc, R exp(dr), a sa, b sb
/// (R = the placed orientation). Identity corrections change nothing, bit for bit.
void apply_correction(const KeyCorrectionValue& c, dvec3& center, dquat& rotation, double& a, double& b);

/// Rotation vector (axis * angle) → unit quaternion.
dquat rotation_from_vector(const dvec3& v);

}  // namespace sd
