// Least-squares ellipses in a plane (Sect. 3.2): a key ellipse is fitted to a cross-section
// with its center fixed (at the joint, or at the section's centroid for intermediate keys).
#pragma once

#include "math/math_types.h"

#include <vector>

namespace sd::fit {

/// An ellipse in plane coordinates: center, unit direction of its first axis (half-axis a),
/// second axis perpendicular to it (half-axis b). Not ordered: a may be smaller than b.
struct Ellipse2 {
    dvec2 center{0.0};
    dvec2 axis{1.0, 0.0};
    double a = 0.0, b = 0.0;
    double rms = 0.0;  ///< RMS radial distance of the points to the ellipse, plane units
    bool valid = false;

    double area() const { return M_PI * a * b; }
    /// Radius of the ellipse in the direction of unit vector d from its center.
    double radius(const dvec2& d) const;
};

/// Weights of the points of a closed polyline for integrals over its length: half of the
/// two adjacent edge lengths, so dense and sparse parts of a mesh count alike.
std::vector<double> arc_length_weights(const std::vector<dvec2>& points);

/// Fits the ellipse x^T M x = 1 (x relative to `center`, M symmetric positive definite) to
/// weighted points by linear least squares on its three coefficients: axis directions and
/// half-axes at once. When the points do not determine a positive definite M (an arc of
/// less than half the ellipse, a degenerate section), falls back to the second moments
/// about the center (for points spread evenly along an ellipse, a^2 = 2 <x'^2>).
/// @param points   plane coordinates, >= 3 (fewer gives an invalid ellipse)
/// @param weights  >= 0, one per point (e.g. arc_length_weights)
Ellipse2 fit_ellipse_fixed_center(const std::vector<dvec2>& points, const std::vector<double>& weights,
                                  const dvec2& center);

}  // namespace sd::fit
