// Exact triangle–triangle intersection test (the narrow phase).
//
// Triangles are closed point sets: two triangles intersect when they share at least one
// point, so touching (a vertex on the other's face, an edge grazing an edge) counts, and
// coplanar triangles intersect when their areas overlap or touch. Every decision is a sign
// of an exact orientation predicate (exact_predicates.h), so the answer is exact for the
// given float coordinates: no tolerance, no missed crossing through round-off.
//
// Method. For two non-degenerate triangles not in a common plane, T1 ∩ T2 is the overlap of
// the segments T1 ∩ plane(T2) and T2 ∩ plane(T1) on the line where the planes meet, and it is
// non-empty exactly when an edge of one triangle meets the other triangle (the overlap's
// ends are edge points). After the usual rejection (all three vertices strictly on one side
// of the other's plane), each edge that reaches the other's plane is tested with the three
// orientations of the edge's line against the triangle's edges. Coplanar triangles are
// tested in the coordinate plane onto which their plane projects one-to-one. Degenerate
// triangles (collinear or coincident vertices) are the union of their edges and are tested
// as segments.
#pragma once

namespace sd::anatomy {

/// Exact test of two closed triangles (p0, p1, p2) and (q0, q1, q2), each point 3 floats.
bool triangles_intersect(const float* p0, const float* p1, const float* p2, const float* q0, const float* q1,
                         const float* q2);

/// The same for double coordinates (used by the tests' analytic cases).
bool triangles_intersect(const double* p0, const double* p1, const double* p2, const double* q0, const double* q1,
                         const double* q2);

/// Exact test of a closed segment [a, b] against a closed triangle (p0, p1, p2) (either may be
/// degenerate).
bool segment_intersects_triangle(const double* a, const double* b, const double* p0, const double* p1,
                                 const double* p2);

}  // namespace sd::anatomy
