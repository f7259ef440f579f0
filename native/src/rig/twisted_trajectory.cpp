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
    // Each key's posed turn R_k and posed center, and the line it turns about (its axis through
    // its posed pivot; none for a key that does not turn about an axis); the sweep twists if
    // any key does.
    struct PosedKey {
        dquat turn;
        dvec3 center;
        bool turns = false;
        dvec3 axis{0.0}, pivot{0.0};
    };
    std::vector<PosedKey> keys(K);
    bool twists = false;
    for (int k = 0; k < K; ++k) {
        PosedKey& key = keys[k];
        const KeyMotion& m = s.motions[k];
        key.turn = glm::normalize(posed.key_rotations()[k] * glm::conjugate(rest.key_rotations()[k]));
        key.center = k < S ? posed.center(k, 0.0) : posed.center(S - 1, 1.0);
        key.turns = m.twist_axis != dvec3(0.0);
        if (key.turns) {
            key.axis = glm::normalize(key.turn * m.twist_axis);
            key.pivot = key.center - key.turn * (s.keys[k].center - m.pivot);
        }
        twists = twists || key.turns;
    }
    if (!twists) return {};
    // The last link's spans (their intermediate key twists about the link) turn every key's
    // term about that one line, the link's: a key turned about its own link (the upper arm's,
    // 8.5 degrees off the forearm's in an A-pose), which shares the forearm's spans through the
    // cardinal functions' lobes, put the forearm's sections up to 0.6 mm off the forearm's
    // turn (MakeHuman's skin 1.013x its rest distance from the bone at 180 degrees, now 1.002).
    // The other spans keep each key's own line: turned about the span's line there too, bends
    // with a little twist about it moved (an elbow at 150 degrees two pairs more than Preserve
    // Volume's, a knee four).
    std::vector<dvec3> line_axis(S), line_point(S);
    std::vector<char> on_line(S, 0);
    for (int span = 0; span < S; ++span) {
        const int c = s.keys[span + 1].is_joint_key() ? span : span + 1;
        if (s.keys[c].is_joint_key() || !s.motions[c].turns_about_pivot) continue;
        on_line[span] = 1;
        line_axis[span] = keys[c].axis;
        line_point[span] = keys[c].pivot;
    }
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
    // The correction E(u) = Σ_k φ_k(u) (T_k(u) - 1) O_k at u = i/6 of each span (O_k the key's
    // posed offset from the line its term turns about): zero at the
    // knots (φ_k is 0 at every other key, and T_k 1 at its own), so five samples a span fit
    // one cubic per half through four points each.
    const auto correction = [&](int span, double u) {
        const dquat f = frame_turn(posed, rest, span, u);
        const dvec3 fv(f.x, f.y, f.z);
        dvec3 e(0.0);
        for (int k = 0; k < K; ++k) {
            if (!on_line[span] && !keys[k].turns) continue;
            const double* c3 = &phi[(static_cast<size_t>(span) * K + k) * 4];
            const double weight = c3[0] + u * (c3[1] + u * (c3[2] + u * c3[3]));
            if (weight == 0.0) continue;
            // The line the key's term turns about: the span's, or the key's own.
            const dvec3& a = on_line[span] ? line_axis[span] : keys[k].axis;
            const dvec3& point = on_line[span] ? line_point[span] : keys[k].pivot;
            // Δ = f conj(R_k): w = f . R_k, and Δ's vector part along a is
            // R_k.w (f_v . a) - f.w (R_k,v . a) - f_v . (R_k,v x a).
            const dquat& r = keys[k].turn;
            const dvec3 rv(r.x, r.y, r.z);
            const double w = f.w * r.w + glm::dot(fv, rv);
            const double p = r.w * glm::dot(fv, a) - f.w * glm::dot(rv, a) - glm::dot(fv, glm::cross(rv, a));
            const double n2 = w * w + p * p;
            if (!(n2 > 0.0)) continue;  // a half turn about a exactly: no twist defined
            const double cos_t = (w * w - p * p) / n2, sin_t = 2.0 * w * p / n2;
            // Rodrigues: the twist turns the key's offset from the line by θ about it.
            const dvec3 offset = keys[k].center - point;
            e += weight * ((cos_t - 1.0) * (offset - a * glm::dot(a, offset)) + sin_t * glm::cross(a, offset));
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
