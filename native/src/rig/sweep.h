// The sweep surface of a moving ellipse (Sect. 3.1–3.2):
//   S(theta, t) = R(t) (a(t) cos theta, b(t) sin theta, 0)^T + C(t),
// with C(t) the cubic trajectory through the key centers (chord-length knots), R(t) the
// rotation of the normalised piecewise-linear quaternion curve Q(t) through the key
// orientations, and N(t) = R(t) e_z the normal of the moving plane P(t).
//
// A point of a sweep is addressed as (span, u): span i runs between keys i and i+1, u in
// [0, 1]; t = t_i + u (t_{i+1} - t_i). Vertex bindings store (span, u), so they stay valid
// when the knots are recomputed for a new pose.
#pragma once

#include "math/interpolating_curves.h"

#include <vector>

namespace sd {

/// C(t) and Q(t) of one sweep in one pose. Rebuilt every frame (Sect. 4.1).
class SweepGeometry {
public:
    SweepGeometry() = default;
    /// @param centers    K >= 2 key centers, distinct
    /// @param rotations  K unit quaternions; signs are made consistent (short arcs)
    SweepGeometry(const std::vector<dvec3>& centers, const std::vector<dquat>& rotations);

    int span_count() const { return static_cast<int>(spans_.size()); }
    const std::vector<double>& knots() const { return knots_; }
    double span_length(int span) const { return knots_[span + 1] - knots_[span]; }
    const CubicSpan& center_span(int span) const { return spans_[span]; }
    /// Key quaternions after the sign fix: q_i . q_{i+1} >= 0.
    const std::vector<dquat>& key_rotations() const { return q_; }

    dvec3 center(int span, double u) const { return spans_[span].value(u); }
    /// C'(t) = dC/dt.
    dvec3 tangent(int span, double u) const { return spans_[span].derivative(u) / span_length(span); }
    /// Q(t) = (1-u) q_i + u q_{i+1}, not normalised.
    dquat raw_rotation(int span, double u) const { return (1.0 - u) * q_[span] + u * q_[span + 1]; }
    dmat3 rotation(int span, double u) const { return glm::mat3_cast(glm::normalize(raw_rotation(span, u))); }
    dvec3 normal(int span, double u) const { return rotation(span, u)[2]; }

    /// Scales the trajectory's tangent at interior key `key` by `factor` (both spans meeting
    /// there, each changed by the Hermite basis function of its end: positions at the keys
    /// stay, and the tangent stays continuous).
    void scale_key_tangent(int key, double factor);

private:
    std::vector<double> knots_;
    std::vector<CubicSpan> spans_;
    std::vector<dquat> q_;
};

/// a(t), b(t): quadratic interpolation of the key half-axes on fixed (rest) knots. Sect. 4.1
/// leaves them untouched by the pose; only the volume controller (Sect. 4.4) changes the key
/// values.
struct HalfAxisFunctions {
    QuadraticCardinalBasis basis;
    std::vector<double> a, b;  ///< key values
    dvec2 at(int span, double u) const {
        return dvec2(basis.evaluate(a.data(), span, u), basis.evaluate(b.data(), span, u));
    }
};

/// S(theta, t) given the geometry and the half-axis functions.
dvec3 sweep_point(const SweepGeometry& g, const HalfAxisFunctions& h, int span, double u, double theta);

/// Maps a global sweep parameter s in [0, 1] (uniform per span) to (span, u).
void split_parameter(int span_count, double s, int* span, double* u);

}  // namespace sd
