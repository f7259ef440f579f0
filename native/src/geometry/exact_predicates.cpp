#include "geometry/exact_predicates.h"

#include <cmath>
#include <limits>
#include <vector>

namespace sd::anatomy {

namespace {

constexpr double kEps = std::numeric_limits<double>::epsilon() / 2;  // 2^-53
// Shewchuk's static bounds for the first-stage evaluation (differences computed in floating
// point, then the determinant).
constexpr double kCcwBound = (3.0 + 16.0 * kEps) * kEps;
constexpr double kO3dBound = (7.0 + 56.0 * kEps) * kEps;

// ---- floating-point expansions (nonoverlapping, increasing magnitude) ------------------

using Expansion = std::vector<double>;

inline void two_sum(double a, double b, double& x, double& y) {
    x = a + b;
    const double bv = x - a, av = x - bv;
    y = (a - av) + (b - bv);
}

inline void two_diff(double a, double b, double& x, double& y) {
    x = a - b;
    const double bv = a - x, av = x + bv;
    y = (a - av) + (bv - b);
}

inline void fast_two_sum(double a, double b, double& x, double& y) {  // |a| >= |b|
    x = a + b;
    y = b - (x - a);
}

inline void two_product(double a, double b, double& x, double& y) {
    x = a * b;
    y = std::fma(a, b, -x);
}

void drop_zeros(Expansion& e) {
    size_t n = 0;
    for (double v : e)
        if (v != 0.0) e[n++] = v;
    e.resize(n);
}

/// e + b (Shewchuk's GROW-EXPANSION).
Expansion grow(const Expansion& e, double b) {
    Expansion h(e.size() + 1);
    double q = b;
    for (size_t i = 0; i < e.size(); ++i) two_sum(q, e[i], q, h[i]);
    h[e.size()] = q;
    drop_zeros(h);
    return h;
}

Expansion sum(const Expansion& e, const Expansion& f) {
    Expansion h = e;
    for (double v : f) h = grow(h, v);
    return h;
}

Expansion negate(Expansion e) {
    for (double& v : e) v = -v;
    return e;
}

/// e * b (Shewchuk's SCALE-EXPANSION).
Expansion scale(const Expansion& e, double b) {
    if (e.empty() || b == 0.0) return {};
    Expansion h(2 * e.size());
    double q, hh;
    two_product(e[0], b, q, hh);
    h[0] = hh;
    for (size_t i = 1; i < e.size(); ++i) {
        double p1, p0, s;
        two_product(e[i], b, p1, p0);
        two_sum(q, p0, s, hh);
        h[2 * i - 1] = hh;
        fast_two_sum(p1, s, q, hh);
        h[2 * i] = hh;
    }
    h[2 * e.size() - 1] = q;
    drop_zeros(h);
    return h;
}

Expansion product(const Expansion& e, const Expansion& f) {
    Expansion h;
    for (double v : f) h = sum(h, scale(e, v));
    return h;
}

Expansion difference(double a, double b) {
    double x, y;
    two_diff(a, b, x, y);
    Expansion e{y, x};
    drop_zeros(e);
    return e;
}

int sign_of(const Expansion& e) {
    for (size_t i = e.size(); i-- > 0;)
        if (e[i] != 0.0) return e[i] > 0.0 ? 1 : -1;
    return 0;
}

}  // namespace

namespace detail {

int orient2d_exact(const double* a, const double* b, const double* c) {
    const Expansion bx = difference(b[0], a[0]), by = difference(b[1], a[1]);
    const Expansion cx = difference(c[0], a[0]), cy = difference(c[1], a[1]);
    return sign_of(sum(product(bx, cy), negate(product(by, cx))));
}

int orient3d_exact(const double* a, const double* b, const double* c, const double* d) {
    Expansion u[3], v[3], w[3];
    for (int i = 0; i < 3; ++i) {
        u[i] = difference(b[i], a[i]);
        v[i] = difference(c[i], a[i]);
        w[i] = difference(d[i], a[i]);
    }
    // (u x v) . w
    const Expansion cx = sum(product(u[1], v[2]), negate(product(u[2], v[1])));
    const Expansion cy = sum(product(u[2], v[0]), negate(product(u[0], v[2])));
    const Expansion cz = sum(product(u[0], v[1]), negate(product(u[1], v[0])));
    return sign_of(sum(sum(product(cx, w[0]), product(cy, w[1])), product(cz, w[2])));
}

}  // namespace detail

int orient2d(const double* a, const double* b, const double* c) {
    const double left = (b[0] - a[0]) * (c[1] - a[1]);
    const double right = (b[1] - a[1]) * (c[0] - a[0]);
    const double det = left - right;
    const double bound = kCcwBound * (std::abs(left) + std::abs(right));
    if (det > bound) return 1;
    if (-det > bound) return -1;
    return detail::orient2d_exact(a, b, c);
}

int orient3d(const double* a, const double* b, const double* c, const double* d) {
    const double ux = b[0] - a[0], uy = b[1] - a[1], uz = b[2] - a[2];
    const double vx = c[0] - a[0], vy = c[1] - a[1], vz = c[2] - a[2];
    const double wx = d[0] - a[0], wy = d[1] - a[1], wz = d[2] - a[2];
    const double uyvz = uy * vz, uzvy = uz * vy;
    const double uzvx = uz * vx, uxvz = ux * vz;
    const double uxvy = ux * vy, uyvx = uy * vx;
    const double det = (uyvz - uzvy) * wx + (uzvx - uxvz) * wy + (uxvy - uyvx) * wz;
    const double permanent = (std::abs(uyvz) + std::abs(uzvy)) * std::abs(wx) +
                             (std::abs(uzvx) + std::abs(uxvz)) * std::abs(wy) +
                             (std::abs(uxvy) + std::abs(uyvx)) * std::abs(wz);
    const double bound = kO3dBound * permanent;
    if (det > bound) return 1;
    if (-det > bound) return -1;
    return detail::orient3d_exact(a, b, c, d);
}

}  // namespace sd::anatomy
