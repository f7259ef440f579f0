// Exact orientation predicates for the narrow phase of collision detection.
//
// Each predicate first evaluates its determinant in double precision with Shewchuk's static
// error bound ("Adaptive Precision Floating-Point Arithmetic and Fast Robust Geometric
// Predicates", 1997); only when the bound cannot certify the sign is the determinant
// recomputed exactly with floating-point expansions. The sign returned is therefore the
// sign of the exact determinant of the (float or double) inputs — no epsilon anywhere.
#pragma once

namespace sd::anatomy {

/// Sign (-1, 0, +1) of ((b - a) x (c - a)) . (d - a): +1 when d lies on the side the normal
/// of the counter-clockwise triangle (a, b, c) points to, 0 when the four points are coplanar.
int orient3d(const double* a, const double* b, const double* c, const double* d);

/// Sign of (b - a) x (c - a) for 2D points: +1 when (a, b, c) turn counter-clockwise.
int orient2d(const double* a, const double* b, const double* c);

namespace detail {
/// The exact fallbacks (exposed for tests): same results as the filtered predicates.
int orient3d_exact(const double* a, const double* b, const double* c, const double* d);
int orient2d_exact(const double* a, const double* b, const double* c);
}  // namespace detail

}  // namespace sd::anatomy
