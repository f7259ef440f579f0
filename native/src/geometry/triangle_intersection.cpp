#include "geometry/triangle_intersection.h"

#include "geometry/exact_predicates.h"

#include <algorithm>
#include <cmath>

namespace sd::anatomy {

namespace {

struct P3 {
    double v[3];
    const double* data() const { return v; }
    double operator[](int i) const { return v[i]; }
};
struct P2 {
    double v[2];
};

P3 to_p3(const float* p) { return {{p[0], p[1], p[2]}}; }
P3 to_p3(const double* p) { return {{p[0], p[1], p[2]}}; }

P2 project(const P3& p, int drop) {
    const int i = drop == 0 ? 1 : 0, j = drop == 2 ? 1 : 2;
    return {{p[i], p[j]}};
}

bool mixed(int a, int b, int c) { return (a > 0 || b > 0 || c > 0) && (a < 0 || b < 0 || c < 0); }

// ---- 2D ------------------------------------------------------------------------------

/// Closed segments [a, b] and [c, d] in 2D, either possibly a point.
bool segments_intersect_2d(const P2& a, const P2& b, const P2& c, const P2& d) {
    const int o1 = orient2d(a.v, b.v, c.v), o2 = orient2d(a.v, b.v, d.v);
    const int o3 = orient2d(c.v, d.v, a.v), o4 = orient2d(c.v, d.v, b.v);
    if (o1 == 0 && o2 == 0 && o3 == 0 && o4 == 0) {
        // All on one line (or points): overlap of the bounding boxes decides.
        for (int k = 0; k < 2; ++k)
            if (std::max(a.v[k], b.v[k]) < std::min(c.v[k], d.v[k]) ||
                std::max(c.v[k], d.v[k]) < std::min(a.v[k], b.v[k]))
                return false;
        return true;
    }
    return o1 * o2 <= 0 && o3 * o4 <= 0;
}

/// Point p in the closed 2D triangle (a, b, c), which must not be degenerate.
bool point_in_triangle_2d(const P2& p, const P2& a, const P2& b, const P2& c) {
    return !mixed(orient2d(a.v, b.v, p.v), orient2d(b.v, c.v, p.v), orient2d(c.v, a.v, p.v));
}

bool triangles_intersect_2d(const P2 (&t)[3], const P2 (&u)[3]) {
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j)
            if (segments_intersect_2d(t[i], t[(i + 1) % 3], u[j], u[(j + 1) % 3])) return true;
    return point_in_triangle_2d(t[0], u[0], u[1], u[2]) || point_in_triangle_2d(u[0], t[0], t[1], t[2]);
}

// ---- 3D helpers ------------------------------------------------------------------------

/// The coordinate axis to drop so that the plane through a non-degenerate triangle projects
/// one-to-one: the largest component of its normal. The normal is computed in double from
/// float differences, so each component has the exact sign and is zero only when exactly
/// zero; the largest is therefore exactly non-zero.
int dominant_axis(const P3& a, const P3& b, const P3& c) {
    const double ux = b[0] - a[0], uy = b[1] - a[1], uz = b[2] - a[2];
    const double vx = c[0] - a[0], vy = c[1] - a[1], vz = c[2] - a[2];
    const double n[3] = {std::abs(uy * vz - uz * vy), std::abs(uz * vx - ux * vz), std::abs(ux * vy - uy * vx)};
    return n[0] >= n[1] && n[0] >= n[2] ? 0 : (n[1] >= n[2] ? 1 : 2);
}

/// True when a, b, c are collinear (or coincide): every coordinate projection is degenerate.
bool degenerate(const P3& a, const P3& b, const P3& c) {
    for (int drop = 0; drop < 3; ++drop) {
        const P2 pa = project(a, drop), pb = project(b, drop), pc = project(c, drop);
        if (orient2d(pa.v, pb.v, pc.v) != 0) return false;
    }
    return true;
}

/// Closed segment [a, b] against a closed non-degenerate triangle t, given the orientations
/// sa, sb of a and b relative to t's plane.
bool segment_triangle_signed(const P3& a, const P3& b, int sa, int sb, const P3 (&t)[3]) {
    if ((sa > 0 && sb > 0) || (sa < 0 && sb < 0)) return false;
    if (sa == 0 && sb == 0) {  // in the triangle's plane
        const int drop = dominant_axis(t[0], t[1], t[2]);
        const P2 pa = project(a, drop), pb = project(b, drop);
        const P2 q[3] = {project(t[0], drop), project(t[1], drop), project(t[2], drop)};
        if (point_in_triangle_2d(pa, q[0], q[1], q[2])) return true;
        for (int j = 0; j < 3; ++j)
            if (segments_intersect_2d(pa, pb, q[j], q[(j + 1) % 3])) return true;
        return false;
    }
    // The line ab is not parallel to the plane and meets it on the closed segment; the
    // meeting point is in the closed triangle unless it is strictly outside an edge.
    return !mixed(orient3d(a.data(), b.data(), t[0].data(), t[1].data()),
                  orient3d(a.data(), b.data(), t[1].data(), t[2].data()),
                  orient3d(a.data(), b.data(), t[2].data(), t[0].data()));
}

/// Closed segments [a, b] and [c, d] in 3D: coplanar, and meeting in every coordinate
/// projection (one of which is one-to-one on their common plane or line).
bool segments_intersect_3d(const P3& a, const P3& b, const P3& c, const P3& d) {
    if (orient3d(a.data(), b.data(), c.data(), d.data()) != 0) return false;
    for (int drop = 0; drop < 3; ++drop)
        if (!segments_intersect_2d(project(a, drop), project(b, drop), project(c, drop), project(d, drop)))
            return false;
    return true;
}

bool intersect(const P3 (&t)[3], const P3 (&u)[3]) {
    // Quick rejection on the bounding boxes (exact: plain comparisons).
    for (int k = 0; k < 3; ++k) {
        const double tmin = std::min({t[0][k], t[1][k], t[2][k]}), tmax = std::max({t[0][k], t[1][k], t[2][k]});
        const double umin = std::min({u[0][k], u[1][k], u[2][k]}), umax = std::max({u[0][k], u[1][k], u[2][k]});
        if (tmax < umin || umax < tmin) return false;
    }
    const bool dt = degenerate(t[0], t[1], t[2]), du = degenerate(u[0], u[1], u[2]);
    if (dt && du) {
        for (int i = 0; i < 3; ++i)
            for (int j = 0; j < 3; ++j)
                if (segments_intersect_3d(t[i], t[(i + 1) % 3], u[j], u[(j + 1) % 3])) return true;
        return false;
    }
    if (dt || du) {
        const P3(&seg)[3] = dt ? t : u;
        const P3(&tri)[3] = dt ? u : t;
        int s[3];
        for (int i = 0; i < 3; ++i) s[i] = orient3d(tri[0].data(), tri[1].data(), tri[2].data(), seg[i].data());
        for (int i = 0; i < 3; ++i)
            if (segment_triangle_signed(seg[i], seg[(i + 1) % 3], s[i], s[(i + 1) % 3], tri)) return true;
        return false;
    }

    int st[3], su[3];  // t's vertices against u's plane, u's against t's
    for (int i = 0; i < 3; ++i) st[i] = orient3d(u[0].data(), u[1].data(), u[2].data(), t[i].data());
    if ((st[0] > 0 && st[1] > 0 && st[2] > 0) || (st[0] < 0 && st[1] < 0 && st[2] < 0)) return false;
    for (int i = 0; i < 3; ++i) su[i] = orient3d(t[0].data(), t[1].data(), t[2].data(), u[i].data());
    if ((su[0] > 0 && su[1] > 0 && su[2] > 0) || (su[0] < 0 && su[1] < 0 && su[2] < 0)) return false;

    if (st[0] == 0 && st[1] == 0 && st[2] == 0) {  // coplanar
        const int drop = dominant_axis(t[0], t[1], t[2]);
        const P2 a[3] = {project(t[0], drop), project(t[1], drop), project(t[2], drop)};
        const P2 b[3] = {project(u[0], drop), project(u[1], drop), project(u[2], drop)};
        return triangles_intersect_2d(a, b);
    }
    // Not coplanar: an edge of one triangle meets the other.
    for (int i = 0; i < 3; ++i)
        if (segment_triangle_signed(t[i], t[(i + 1) % 3], st[i], st[(i + 1) % 3], u)) return true;
    for (int i = 0; i < 3; ++i)
        if (segment_triangle_signed(u[i], u[(i + 1) % 3], su[i], su[(i + 1) % 3], t)) return true;
    return false;
}

}  // namespace

bool triangles_intersect(const float* p0, const float* p1, const float* p2, const float* q0, const float* q1,
                         const float* q2) {
    const P3 t[3] = {to_p3(p0), to_p3(p1), to_p3(p2)};
    const P3 u[3] = {to_p3(q0), to_p3(q1), to_p3(q2)};
    return intersect(t, u);
}

bool triangles_intersect(const double* p0, const double* p1, const double* p2, const double* q0, const double* q1,
                         const double* q2) {
    const P3 t[3] = {to_p3(p0), to_p3(p1), to_p3(p2)};
    const P3 u[3] = {to_p3(q0), to_p3(q1), to_p3(q2)};
    return intersect(t, u);
}

bool segment_intersects_triangle(const double* a, const double* b, const double* p0, const double* p1,
                                 const double* p2) {
    const P3 s[2] = {to_p3(a), to_p3(b)};
    const P3 t[3] = {to_p3(p0), to_p3(p1), to_p3(p2)};
    if (degenerate(t[0], t[1], t[2])) {
        for (int j = 0; j < 3; ++j)
            if (segments_intersect_3d(s[0], s[1], t[j], t[(j + 1) % 3])) return true;
        return false;
    }
    const int sa = orient3d(p0, p1, p2, a), sb = orient3d(p0, p1, p2, b);
    return segment_triangle_signed(s[0], s[1], sa, sb, t);
}

}  // namespace sd::anatomy
