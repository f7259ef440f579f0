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

bool has_twisted_trajectory(const Sweep& sweep) {
    for (const KeyMotion& m : sweep.motions)
        if (m.twist_axis != dvec3(0.0)) return true;
    return false;
}

std::vector<std::array<CubicSpan, 2>> twisted_trajectory(const Sweep& s, const SweepGeometry& posed,
                                                         const std::vector<dquat>& rest_rotations) {
    const int K = s.key_count(), S = posed.span_count();
    const SweepGeometry& rest = s.rest_geometry;
    // Each key that turns about an axis: its cardinal function φ_k, its posed turn R_k, and
    // what turning its posed offset O_k about its posed axis a_k takes (per frame sample, the
    // twist about a_k of Δ = R(u) R_rest(u)^-1 R_k^-1, in closed form: no square root).
    struct Turning {
        std::vector<CubicSpan> phi;
        dquat turn;
        dvec3 axis, turn_along_axis_cross;  // a_k; (R_k's vector part) x a_k
        double turn_along_axis;             // (R_k's vector part) . a_k
        dvec3 offset, across, along;        // O_k; a_k x O_k; a_k (a_k . O_k)
    };
    std::vector<Turning> turning;
    for (int k = 0; k < K; ++k) {
        const KeyMotion& m = s.motions[k];
        if (m.twist_axis == dvec3(0.0)) continue;
        std::vector<dvec3> unit(K, dvec3(0.0));
        unit[k].x = 1.0;
        Turning t;
        t.phi = interpolate_cubic(unit, posed.knots());
        t.turn = glm::normalize(posed.key_rotations()[k] * glm::conjugate(rest_rotations[k]));
        t.axis = glm::normalize(t.turn * m.twist_axis);
        const dvec3 tv(t.turn.x, t.turn.y, t.turn.z);
        t.turn_along_axis = glm::dot(tv, t.axis);
        t.turn_along_axis_cross = glm::cross(tv, t.axis);
        t.offset = t.turn * (s.keys[k].center - m.pivot);
        t.across = glm::cross(t.axis, t.offset);
        t.along = t.axis * glm::dot(t.axis, t.offset);
        turning.push_back(std::move(t));
    }
    std::vector<std::array<CubicSpan, 2>> out(S);
    for (int span = 0; span < S; ++span)
        for (int half = 0; half < 2; ++half) {
            const double u0 = 0.5 * half, h = 0.5 / 3.0;
            std::array<dvec3, 4> y;
            for (int i = 0; i < 4; ++i) {
                const double u = u0 + i * h;
                const dquat f = frame_turn(posed, rest, span, u);
                const dvec3 fv(f.x, f.y, f.z);
                dvec3 c = posed.center(span, u);
                for (const Turning& t : turning) {
                    const double phi = t.phi[span].value(u).x;
                    if (phi == 0.0) continue;
                    // Δ = f conj(R_k): w = f . R_k, and Δ's vector part along a_k is
                    // R_k.w (f_v . a) - f.w (R_k,v . a) - f_v . (R_k,v x a).
                    const double w = f.w * t.turn.w + glm::dot(fv, dvec3(t.turn.x, t.turn.y, t.turn.z));
                    const double p = t.turn.w * glm::dot(fv, t.axis) - f.w * t.turn_along_axis -
                                     glm::dot(fv, t.turn_along_axis_cross);
                    const double n2 = w * w + p * p;
                    if (!(n2 > 0.0)) continue;  // a half turn about a_k exactly: no twist defined
                    const double cos_t = (w * w - p * p) / n2, sin_t = 2.0 * w * p / n2;
                    // Rodrigues: the twist turns O_k by θ about a_k.
                    c += phi * ((cos_t - 1.0) * (t.offset - t.along) + sin_t * t.across);
                }
                y[i] = c;
            }
            out[span][half] = cubic_through(y, u0, h);
        }
    return out;
}

}  // namespace sd
