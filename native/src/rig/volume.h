// Sweep volume and its control (Sect. 3.1 and 4.4).
//
//   V = ∫ π a(t) b(t) <N(t), C'(t)> dt
//
// is exact for a sweep of ellipses centred on C(t) without self-intersection. It is
// parameterisation invariant, so each span is integrated in its own u with dC/du. Because
// a(t) = Σ a_k φ_k(t) is linear in the key half-axes, ∂V/∂a_k = ∫ π φ_k b <N, C'> dt.
#pragma once

#include "rig/sweep.h"

#include <vector>

namespace sd {

/// Gauss–Legendre nodes over every half-span of a sweep, with φ_k tabulated at each node.
struct VolumeQuadrature {
    static constexpr int kNodesPerHalf = 4;
    std::vector<int> span;          ///< #nodes
    std::vector<double> u, weight;  ///< #nodes, weight in u
    std::vector<double> phi;        ///< #nodes * K
    int key_count = 0;

    VolumeQuadrature() = default;
    explicit VolumeQuadrature(const QuadraticCardinalBasis& basis);
    int node_count() const { return static_cast<int>(u.size()); }
};

/// g(u) = π <N(u), dC/du> at every node: the pose-dependent part of the integrand.
std::vector<double> volume_density(const VolumeQuadrature& q, const SweepGeometry& g);

/// V for key half-axes a, b (#K each); if grad_a/grad_b are given, also ∂V/∂a_k, ∂V/∂b_k.
double sweep_volume(const VolumeQuadrature& q, const std::vector<double>& density, const double* a, const double* b,
                    double* grad_a = nullptr, double* grad_b = nullptr);

/// The volume in one pose as a bilinear form of the key half-axes: V(a, b) = a^T M b with
/// M_kl = Σ_nodes w g φ_k φ_l. Built once per frame, it makes each controller step O(K²).
struct VolumeForm {
    std::vector<double> m;  ///< K*K, row-major
    int key_count = 0;
    VolumeForm(const VolumeQuadrature& q, const std::vector<double>& density);
    /// V for key half-axes a, b; optional gradients ∂V/∂a = M b, ∂V/∂b = M^T a.
    double volume(const double* a, const double* b, double* grad_a = nullptr, double* grad_b = nullptr) const;
};

/// Which keys the controller may rescale, in the paper's order.
struct VolumeControlKeys {
    std::vector<int> joints;      ///< first: interior joint keys (elbow, knee, spine joints)
    std::vector<int> neighbours;  ///< then also: their neighbours
};
VolumeControlKeys volume_control_keys(const std::vector<bool>& is_joint_key);

struct VolumeControlResult {
    double before = 0, after = 0;
    int iterations = 0;
};

/// The volume controller's tolerance: a sweep within this share of its target is left alone.
constexpr double kVolumeTolerance = 2e-4;

/// The controller of Sect. 4.4: starting from the rest half-axes, repeat the smallest step
/// of the keys' scales (a_k / a0_k, b_k / b0_k) that reaches V_target to first order,
///   Δa_k = a0_k² ∂V/∂a_k (V_target − V) / Σ (a0_l² (∂V/∂a_l)² + b0_l² (∂V/∂b_l)²),
/// over the joint keys and their neighbours (the paper: joints alone for two iterations),
/// until |V − V_target| / V_target <= tolerance or `max_iterations` steps were taken.
/// Half-axes stay within 10 % .. 10x of their rest values.
/// @param a, b  in: rest key half-axes; out: controlled ones (#K each)
VolumeControlResult control_volume(const VolumeForm& form, const VolumeControlKeys& keys, double target,
                                   std::vector<double>& a, std::vector<double>& b, double tolerance = kVolumeTolerance,
                                   int max_iterations = 5);

}  // namespace sd
