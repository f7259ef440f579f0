#include "math/interpolating_curves.h"

#include <Eigen/Dense>

#include <cmath>

namespace sd {

std::vector<double> chord_length_knots(const std::vector<dvec3>& points) {
    if (points.size() < 2) throw InvalidInput("a sweep needs at least two key ellipses");
    std::vector<double> knots(points.size(), 0.0);
    for (size_t i = 1; i < points.size(); ++i) knots[i] = knots[i - 1] + glm::length(points[i] - points[i - 1]);
    const double total = knots.back();
    for (size_t i = 1; i < points.size(); ++i) {
        if (!(knots[i] - knots[i - 1] > 1e-9 * total) || !std::isfinite(knots[i]))
            throw InvalidInput("key ellipses " + std::to_string(i - 1) + " and " + std::to_string(i) +
                               " of a sweep have the same center");
    }
    return knots;
}

std::vector<CubicSpan> interpolate_cubic(const std::vector<dvec3>& p, const std::vector<double>& t) {
    const size_t n = p.size() - 1;  // spans
    // Second derivatives M_i with M_0 = M_n = 0 from the tridiagonal C2 conditions
    // (Thomas algorithm; diagonally dominant, so no pivoting is needed).
    std::vector<dvec3> m(n + 1, dvec3(0.0));
    if (n >= 2) {
        std::vector<double> diag(n + 1), upper(n + 1);
        std::vector<dvec3> rhs(n + 1);
        for (size_t i = 1; i < n; ++i) {
            const double h0 = t[i] - t[i - 1], h1 = t[i + 1] - t[i];
            diag[i] = 2.0 * (h0 + h1);
            upper[i] = h1;
            rhs[i] = 6.0 * ((p[i + 1] - p[i]) / h1 - (p[i] - p[i - 1]) / h0);
        }
        for (size_t i = 2; i < n; ++i) {  // forward elimination; lower[i] = h_{i-1}
            const double lower = t[i] - t[i - 1];
            const double f = lower / diag[i - 1];
            diag[i] -= f * upper[i - 1];
            rhs[i] -= f * rhs[i - 1];
        }
        for (size_t i = n - 1; i >= 1; --i) m[i] = (rhs[i] - upper[i] * m[i + 1]) / diag[i];
    }
    // Power form per span in u = (t - t_i) / h:
    // C(u) = P_i + u (P_{i+1} - P_i) + h^2/6 [M_i (-2u + 3u^2 - u^3) + M_{i+1} (u^3 - u)].
    std::vector<CubicSpan> spans(n);
    for (size_t i = 0; i < n; ++i) {
        const double h = t[i + 1] - t[i], h26 = h * h / 6.0;
        CubicSpan& s = spans[i];
        s.c[0] = p[i];
        s.c[1] = (p[i + 1] - p[i]) - h26 * (2.0 * m[i] + m[i + 1]);
        s.c[2] = 3.0 * h26 * m[i];
        s.c[3] = h26 * (m[i + 1] - m[i]);
    }
    return spans;
}

namespace {

/// Values of all B-spline basis functions of degree `deg` over knot vector `U` at x
/// (Cox–de Boor, Piegl & Tiller A2.2), written into `out` (size U.size() - deg - 1).
void bspline_basis(const std::vector<double>& U, int deg, double x, std::vector<double>& out) {
    const int nb = static_cast<int>(U.size()) - deg - 1;
    std::fill(out.begin(), out.end(), 0.0);
    int k = deg;  // span index: U[k] <= x < U[k+1], clamped to the last non-empty span
    while (k < nb - 1 && x >= U[k + 1]) ++k;
    std::vector<double> N(deg + 1, 0.0), left(deg + 1), right(deg + 1);
    N[0] = 1.0;
    for (int j = 1; j <= deg; ++j) {
        left[j] = x - U[k + 1 - j];
        right[j] = U[k + j] - x;
        double saved = 0.0;
        for (int r = 0; r < j; ++r) {
            const double tmp = N[r] / (right[r + 1] + left[j - r]);
            N[r] = saved + right[r + 1] * tmp;
            saved = left[j - r] * tmp;
        }
        N[j] = saved;
    }
    for (int j = 0; j <= deg; ++j) out[k - deg + j] = N[j];
}

}  // namespace

QuadraticCardinalBasis::QuadraticCardinalBasis(const std::vector<double>& t) {
    keys_ = static_cast<int>(t.size());
    const int n = keys_ - 1;
    const int deg = n >= 2 ? 2 : 1;
    std::vector<double> U;
    for (int i = 0; i <= deg; ++i) U.push_back(t.front());
    for (int i = 1; i + 1 < n; ++i) U.push_back(0.5 * (t[i] + t[i + 1]));
    for (int i = 0; i <= deg; ++i) U.push_back(t.back());

    // Collocation matrix A_ij = N_j(t_i); the cardinal functions are phi = N A^-1.
    Eigen::MatrixXd A(keys_, keys_);
    std::vector<double> row(keys_);
    for (int i = 0; i < keys_; ++i) {
        bspline_basis(U, deg, t[i], row);
        for (int j = 0; j < keys_; ++j) A(i, j) = row[j];
    }
    const Eigen::MatrixXd inv = A.partialPivLu().inverse();

    // On each half-span every phi_k is a single quadratic: recover its power form in u
    // from three samples (exact up to rounding).
    coef_.assign(static_cast<size_t>(n) * 2 * keys_ * 3, 0.0);
    Eigen::Matrix3d vander;
    for (int s = 0; s < n; ++s) {
        const double h = t[s + 1] - t[s];
        for (int half = 0; half < 2; ++half) {
            const double us[3] = {0.5 * half, 0.5 * half + 0.25, 0.5 * half + 0.5};
            Eigen::MatrixXd samples(3, keys_);
            for (int r = 0; r < 3; ++r) {
                vander.row(r) << 1.0, us[r], us[r] * us[r];
                bspline_basis(U, deg, t[s] + us[r] * h, row);
                for (int k = 0; k < keys_; ++k) {
                    double v = 0.0;
                    for (int j = 0; j < keys_; ++j) v += row[j] * inv(j, k);
                    samples(r, k) = v;
                }
            }
            const Eigen::MatrixXd c = vander.partialPivLu().solve(samples);
            for (int k = 0; k < keys_; ++k)
                for (int r = 0; r < 3; ++r) coef_[((static_cast<size_t>(s) * 2 + half) * keys_ + k) * 3 + r] = c(r, k);
        }
    }
}

double QuadraticCardinalBasis::phi(int key, int span, double u) const {
    const double* c = coefficients(span, u < 0.5 ? 0 : 1, key);
    return c[0] + u * (c[1] + u * c[2]);
}

double QuadraticCardinalBasis::evaluate(const double* values, int span, double u) const {
    double sum = 0.0;
    for (int k = 0; k < keys_; ++k) sum += values[k] * phi(k, span, u);
    return sum;
}

}  // namespace sd
