#include "fit/ellipse_fit.h"

#include <algorithm>
#include <cmath>

namespace sd::fit {

double Ellipse2::radius(const dvec2& d) const {
    const double c = glm::dot(d, axis), s = d.x * -axis.y + d.y * axis.x;
    return 1.0 / std::sqrt(c * c / (a * a) + s * s / (b * b));
}

std::vector<double> arc_length_weights(const std::vector<dvec2>& p) {
    const size_t n = p.size();
    std::vector<double> w(n, 0.0);
    for (size_t i = 0; i < n; ++i) {
        const double len = glm::length(p[(i + 1) % n] - p[i]);
        w[i] += 0.5 * len;
        w[(i + 1) % n] += 0.5 * len;
    }
    return w;
}

namespace {

/// Eigen-decomposition of the symmetric 2x2 matrix [[p, q], [q, r]]: eigenvalues l1 >= l2
/// and the unit eigenvector of l1.
void symmetric_eigen(double p, double q, double r, double* l1, double* l2, dvec2* e1) {
    const double mean = 0.5 * (p + r), diff = 0.5 * (p - r);
    const double root = std::sqrt(diff * diff + q * q);
    *l1 = mean + root;
    *l2 = mean - root;
    // Angle of the first eigenvector: 0.5 atan2(2q, p - r).
    const double angle = 0.5 * std::atan2(2.0 * q, p - r);
    *e1 = dvec2(std::cos(angle), std::sin(angle));
}

double rms_distance(const Ellipse2& e, const std::vector<dvec2>& points, const std::vector<double>& w) {
    double sum = 0.0, wsum = 0.0;
    for (size_t i = 0; i < points.size(); ++i) {
        const dvec2 d = points[i] - e.center;
        const double r = glm::length(d);
        if (!(r > 0.0)) continue;
        const double err = r - e.radius(d / r);
        sum += w[i] * err * err;
        wsum += w[i];
    }
    return wsum > 0.0 ? std::sqrt(sum / wsum) : 0.0;
}

}  // namespace

Ellipse2 fit_ellipse_fixed_center(const std::vector<dvec2>& points, const std::vector<double>& weights,
                                  const dvec2& center) {
    Ellipse2 e;
    e.center = center;
    if (points.size() < 3 || weights.size() != points.size()) return e;
    // Scale to unit size so the normal equations are well conditioned in any unit.
    double scale = 0.0, wsum = 0.0;
    for (size_t i = 0; i < points.size(); ++i) {
        scale += weights[i] * glm::length(points[i] - center);
        wsum += weights[i];
    }
    if (!(wsum > 0.0) || !(scale > 0.0)) return e;
    scale /= wsum;

    // Normal equations of min Σ w (A x² + 2B xy + C y² − 1)², then twice again with each
    // residual divided by the gradient's length (Sampson's approximation of the geometric
    // distance), which removes the algebraic fit's bias towards the far points.
    const auto det3 = [](const double m[3][3]) {
        return m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1]) - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0]) +
               m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]);
    };
    double coef[3] = {0, 0, 0};
    bool solved = false;
    double sxx = 0, sxy = 0, syy = 0;
    for (int pass = 0; pass < 3; ++pass) {
        double n[3][3] = {{0, 0, 0}, {0, 0, 0}, {0, 0, 0}}, rhs[3] = {0, 0, 0};
        for (size_t i = 0; i < points.size(); ++i) {
            const dvec2 q = (points[i] - center) / scale;
            double w = weights[i];
            if (pass > 0) {
                const dvec2 grad(coef[0] * q.x + coef[1] * q.y, coef[1] * q.x + coef[2] * q.y);
                w /= std::max(glm::dot(grad, grad), 1e-12);
            }
            const double row[3] = {q.x * q.x, 2.0 * q.x * q.y, q.y * q.y};
            for (int r = 0; r < 3; ++r) {
                for (int c = 0; c < 3; ++c) n[r][c] += w * row[r] * row[c];
                rhs[r] += w * row[r];
            }
            if (pass == 0) {
                sxx += weights[i] * q.x * q.x;
                sxy += weights[i] * q.x * q.y;
                syy += weights[i] * q.y * q.y;
            }
        }
        const double det = det3(n);
        if (!(std::abs(det) > 1e-14 * std::pow(n[0][0] + n[1][1] + n[2][2], 3))) break;
        double next[3];
        for (int k = 0; k < 3; ++k) {
            double m[3][3];
            for (int r = 0; r < 3; ++r)
                for (int c = 0; c < 3; ++c) m[r][c] = c == k ? rhs[r] : n[r][c];
            next[k] = det3(m) / det;
        }
        // Keep only positive definite solutions (an ellipse); otherwise stop refining.
        if (!(next[0] > 0.0 && next[0] * next[2] - next[1] * next[1] > 0.0)) break;
        std::copy(next, next + 3, coef);
        solved = true;
    }
    double l1 = 0, l2 = 0;
    dvec2 e1(1, 0);
    if (solved) symmetric_eigen(coef[0], coef[1], coef[2], &l1, &l2, &e1);
    if (solved && l2 > 0.0 && std::isfinite(l1)) {
        // x^T M x = 1: half-axis 1/sqrt(λ) along each eigenvector; λ1 is the short axis.
        e.axis = dvec2(-e1.y, e1.x);
        e.a = scale / std::sqrt(l2);
        e.b = scale / std::sqrt(l1);
    } else {
        // Second moments about the fixed center.
        symmetric_eigen(sxx / wsum, sxy / wsum, syy / wsum, &l1, &l2, &e1);
        if (!(l2 > 0.0)) return e;
        e.axis = e1;
        e.a = scale * std::sqrt(2.0 * l1);
        e.b = scale * std::sqrt(2.0 * l2);
    }
    e.valid = std::isfinite(e.a) && std::isfinite(e.b) && e.a > 0.0 && e.b > 0.0;
    if (e.valid) e.rms = rms_distance(e, points, weights);
    return e;
}

}  // namespace sd::fit
