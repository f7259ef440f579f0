#include "rig/twisted_trajectory.h"

#include <glm/gtc/quaternion.hpp>

namespace sd {

namespace {

/// R(u) R_rest(u)^-1 at (span, u): the frames' turn since rest, as the kernel blends them.
dquat frame_turn(const SweepGeometry& posed, const SweepGeometry& rest, int span, double u) {
    return glm::normalize(posed.raw_rotation(span, u)) * glm::conjugate(glm::normalize(rest.raw_rotation(span, u)));
}

/// The cubic in u through four samples at u_i = u0 + i h.
CubicSpan cubic_through(const std::array<dvec3, 4>& y, double u0, double h) {
    // Newton's divided differences in s = (u - u0) / h at s = 0, 1, 2, 3, then power form in u.
    const dvec3 d1 = y[1] - y[0], d2 = 0.5 * (y[2] - 2.0 * y[1] + y[0]),
                d3 = (y[3] - 3.0 * y[2] + 3.0 * y[1] - y[0]) / 6.0;
    // p(s) = y0 + d1 s + d2 s (s - 1) + d3 s (s - 1)(s - 2) = e0 + e1 s + e2 s^2 + e3 s^3
    const dvec3 e0 = y[0], e1 = d1 - d2 + 2.0 * d3, e2 = d2 - 3.0 * d3, e3 = d3;
    // s = (u - u0) / h
    const double g = 1.0 / h, g2 = g * g, g3 = g2 * g;
    CubicSpan c;
    c.c[0] = e0 - e1 * (u0 * g) + e2 * (u0 * u0 * g2) - e3 * (u0 * u0 * u0 * g3);
    c.c[1] = e1 * g - 2.0 * e2 * (u0 * g2) + 3.0 * e3 * (u0 * u0 * g3);
    c.c[2] = e2 * g2 - 3.0 * e3 * (u0 * g3);
    c.c[3] = e3 * g3;
    return c;
}

}  // namespace

std::vector<std::array<CubicSpan, 2>> twisted_trajectory(const Sweep& s, const SweepGeometry& posed) {
    const int K = s.key_count(), S = posed.span_count();
    const SweepGeometry& rest = s.rest_geometry;  // the frames the binding was made in
    // Each key that turns about an axis: its posed turn R_k, and
    // what turning its posed offset O_k about its posed axis a_k takes (per frame sample, the
    // twist about a_k of Δ = R(u) R_rest(u)^-1 R_k^-1, in closed form: no square root).
    struct Turning {
        int key;
        dquat turn;
        dvec3 axis, turn_along_axis_cross;  // a_k; (R_k's vector part) x a_k
        double turn_along_axis;             // (R_k's vector part) . a_k
        dvec3 offset, across, along;        // O_k; a_k x O_k; a_k (a_k . O_k)
    };
    std::vector<Turning> turning;
    for (int k = 0; k < K; ++k) {
        const KeyMotion& m = s.motions[k];
        if (m.twist_axis == dvec3(0.0)) continue;
        Turning t;
        t.key = k;
        t.turn = glm::normalize(posed.key_rotations()[k] * glm::conjugate(rest.key_rotations()[k]));
        t.axis = glm::normalize(t.turn * m.twist_axis);
        const dvec3 tv(t.turn.x, t.turn.y, t.turn.z);
        t.turn_along_axis = glm::dot(tv, t.axis);
        t.turn_along_axis_cross = glm::cross(tv, t.axis);
        t.offset = t.turn * (s.keys[k].center - m.pivot);
        t.across = glm::cross(t.axis, t.offset);
        t.along = t.axis * glm::dot(t.axis, t.offset);
        turning.push_back(t);
    }
    if (turning.empty()) return {};
    // The cardinal functions φ_k on the posed knots, three keys a spline (one per coordinate):
    // phi[(span * K + k) * 4 + i], power form in the span's u.
    std::vector<double> phi(static_cast<size_t>(S) * K * 4);
    for (int k0 = 0; k0 < K; k0 += 3) {
        std::vector<dvec3> unit(K, dvec3(0.0));
        for (int c = 0; c < 3 && k0 + c < K; ++c) unit[k0 + c][c] = 1.0;
        const std::vector<CubicSpan> spans = interpolate_cubic(unit, posed.knots());
        for (int span = 0; span < S; ++span)
            for (int c = 0; c < 3 && k0 + c < K; ++c)
                for (int i = 0; i < 4; ++i) phi[(static_cast<size_t>(span) * K + k0 + c) * 4 + i] = spans[span].c[i][c];
    }
    // The correction E(u) = Σ_k φ_k(u) (T_k(u) - 1) O_k at u = i/6 of each span: zero at the
    // knots (φ_k is 0 at every other key, and T_k 1 at its own), so five samples a span fit
    // one cubic per half through four points each.
    const auto correction = [&](int span, double u) {
        const dquat f = frame_turn(posed, rest, span, u);
        const dvec3 fv(f.x, f.y, f.z);
        dvec3 e(0.0);
        for (const Turning& t : turning) {
            const double* c3 = &phi[(static_cast<size_t>(span) * K + t.key) * 4];
            const double weight = c3[0] + u * (c3[1] + u * (c3[2] + u * c3[3]));
            if (weight == 0.0) continue;
            // Δ = f conj(R_k): w = f . R_k, and Δ's vector part along a_k is
            // R_k.w (f_v . a) - f.w (R_k,v . a) - f_v . (R_k,v x a).
            const double w = f.w * t.turn.w + glm::dot(fv, dvec3(t.turn.x, t.turn.y, t.turn.z));
            const double p =
                t.turn.w * glm::dot(fv, t.axis) - f.w * t.turn_along_axis - glm::dot(fv, t.turn_along_axis_cross);
            const double n2 = w * w + p * p;
            if (!(n2 > 0.0)) continue;  // a half turn about a_k exactly: no twist defined
            const double cos_t = (w * w - p * p) / n2, sin_t = 2.0 * w * p / n2;
            // Rodrigues: the twist turns O_k by θ about a_k.
            e += weight * ((cos_t - 1.0) * (t.offset - t.along) + sin_t * t.across);
        }
        return e;
    };
    std::vector<std::array<CubicSpan, 2>> out(S);
    for (int span = 0; span < S; ++span) {
        std::array<dvec3, 7> e;
        e[0] = e[6] = dvec3(0.0);
        for (int i = 1; i < 6; ++i) e[i] = correction(span, i / 6.0);
        const CubicSpan& paper = posed.center_span(span);
        for (int half = 0; half < 2; ++half) {
            const CubicSpan fit =
                cubic_through({e[3 * half], e[3 * half + 1], e[3 * half + 2], e[3 * half + 3]}, 0.5 * half, 1.0 / 6.0);
            for (int i = 0; i < 4; ++i) out[span][half].c[i] = paper.c[i] + fit.c[i];
        }
    }
    return out;
}

}  // namespace sd
