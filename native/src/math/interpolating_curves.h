// Interpolating splines used by a sweep (Sect. 3.2 of Hyun et al. 2005):
//  - the trajectory C(t): a C2 cubic spline through the key centers, chord-length knots;
//  - the half-axis functions a(t), b(t): quadratic B-splines interpolating the key values.
// Both are handed out per span [t_i, t_{i+1}] in a local parameter u in [0, 1] and in power
// form, so that evaluating them per vertex is a short Horner scheme.
#pragma once

#include "math/math_types.h"

#include <vector>

namespace sd {

/// Cumulative chord-length knots t_0 = 0, t_{i+1} = t_i + |p_{i+1} - p_i|.
/// @param points  n >= 2 points
/// @throws InvalidInput when two consecutive points coincide (relative to the total length).
std::vector<double> chord_length_knots(const std::vector<dvec3>& points);

/// One cubic span of C: C(u) = c[0] + c[1] u + c[2] u^2 + c[3] u^3, u in [0, 1].
struct CubicSpan {
    dvec3 c[4];
    dvec3 value(double u) const { return c[0] + u * (c[1] + u * (c[2] + u * c[3])); }
    /// dC/du; divide by the span's knot interval to get dC/dt.
    dvec3 derivative(double u) const { return c[1] + u * (2.0 * c[2] + u * 3.0 * c[3]); }
};

/// The C2 cubic spline through `points` at `knots` with natural end conditions (zero second
/// derivative at both ends); with two points it is the straight segment.
/// @return points.size()-1 spans, span i maps u in [0,1] to t = t_i + u (t_{i+1} - t_i).
std::vector<CubicSpan> interpolate_cubic(const std::vector<dvec3>& points, const std::vector<double>& knots);

/// Quadratic interpolation at the knots t_0..t_n as cardinal functions phi_k (phi_k(t_i) =
/// delta_ik), so that a(t) = sum_k a_k phi_k(t) is linear in the key values — which is what
/// makes the volume gradient of Sect. 4.4 exact and cheap.
///
/// The spline has degree min(2, n) and, following de Boor, interior knots at the midpoints
/// of the interior data intervals, which keeps interpolation well posed. Every span is split
/// at u = 0.5 into two halves on which each phi_k is one quadratic polynomial in u.
class QuadraticCardinalBasis {
public:
    QuadraticCardinalBasis() = default;
    explicit QuadraticCardinalBasis(const std::vector<double>& knots);

    int key_count() const { return keys_; }
    int span_count() const { return keys_ - 1; }
    /// Power-form coefficients (in u of the span, not of the half) of phi_k on a half-span.
    const double* coefficients(int span, int half, int key) const {
        return &coef_[((static_cast<size_t>(span) * 2 + half) * keys_ + key) * 3];
    }
    double phi(int key, int span, double u) const;
    /// sum_k values[k] phi_k at (span, u).
    double evaluate(const double* values, int span, double u) const;

private:
    int keys_ = 0;
    std::vector<double> coef_;  // [span][half][key][3]
};

}  // namespace sd
