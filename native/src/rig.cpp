#include "rig.h"

#include <cmath>

namespace sd {

namespace {
std::string key_name(size_t k) { return "key ellipse " + std::to_string(k); }
bool finite(const dvec3& v) { return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z); }
}  // namespace

Sweep make_sweep(std::vector<KeyEllipse> keys, const Skeleton& skeleton) {
    const int B = skeleton.bone_count();
    if (keys.size() < 2 || keys.size() > 256)
        throw InvalidInput("a sweep needs 2..256 key ellipses, got " + std::to_string(keys.size()));
    std::vector<dvec3> centers;
    std::vector<dquat> rotations;
    std::vector<bool> is_joint;
    for (size_t k = 0; k < keys.size(); ++k) {
        KeyEllipse& e = keys[k];
        if (!finite(e.center)) throw InvalidInput(key_name(k) + ": center is not finite");
        // Callers normalise (the ABI does, from float input); here it is only checked, so a
        // rig read back from a blob is bit-for-bit the rig that was saved.
        const double qn = std::sqrt(glm::dot(e.orientation, e.orientation));
        if (!std::isfinite(qn) || std::abs(qn - 1.0) > 1e-9)
            throw InvalidInput(key_name(k) + ": orientation is not a unit quaternion (|q| = " +
                               std::to_string(qn) + ")");
        if (!(e.a > 0.0) || !(e.b > 0.0) || !std::isfinite(e.a) || !std::isfinite(e.b))
            throw InvalidInput(key_name(k) + ": half-axes must be finite and > 0");
        if (e.bone < 0 || e.bone >= B)
            throw InvalidInput(key_name(k) + ": bone " + std::to_string(e.bone) +
                               " is out of range 0.." + std::to_string(B - 1));
        if (e.joint_parent < -1 || e.joint_parent >= B || e.joint_parent == e.bone)
            throw InvalidInput(key_name(k) + ": joint parent " + std::to_string(e.joint_parent) +
                               " is out of range or equals its bone");
        for (double f : {e.swing_fraction, e.twist_fraction})
            if (!(f >= 0.0 && f <= 1.0))
                throw InvalidInput(key_name(k) + ": swing/twist fractions must be in [0, 1]");
        centers.push_back(e.center);
        rotations.push_back(e.orientation);
        is_joint.push_back(e.is_joint_key());
    }
    Sweep s;
    s.rest_geometry = SweepGeometry(centers, rotations);
    for (int k = 0; k < static_cast<int>(keys.size()); ++k) {
        const int span = k < static_cast<int>(keys.size()) - 1 ? k : k - 1;
        const double u = k < static_cast<int>(keys.size()) - 1 ? 0.0 : 1.0;
        if (!(glm::dot(keys[k].normal(), s.rest_geometry.tangent(span, u)) > 0.0))
            throw InvalidInput(key_name(k) + ": its normal (third column) must point along "
                                             "the sweep, towards the next key");
    }
    s.rest_half_axes.basis = QuadraticCardinalBasis(s.rest_geometry.knots());
    for (const KeyEllipse& e : keys) {
        s.rest_half_axes.a.push_back(e.a);
        s.rest_half_axes.b.push_back(e.b);
    }
    // a(t), b(t) may overshoot between keys; a negative half-axis would turn the sweep
    // inside out, so such key values are refused.
    for (int span = 0; span < s.rest_geometry.span_count(); ++span)
        for (int i = 0; i <= 16; ++i) {
            const dvec2 ab = s.rest_half_axes.at(span, i / 16.0);
            if (!(ab.x > 0.0) || !(ab.y > 0.0))
                throw InvalidInput("between key ellipses " + std::to_string(span) + " and " +
                                   std::to_string(span + 1) +
                                   " the interpolated half-axes become <= 0; "
                                   "neighbouring half-axes differ too much");
        }
    s.quadrature = VolumeQuadrature(s.rest_half_axes.basis);
    s.control_keys = volume_control_keys(is_joint);
    s.rest_volume = sweep_volume(s.quadrature, volume_density(s.quadrature, s.rest_geometry),
                                 s.rest_half_axes.a.data(), s.rest_half_axes.b.data());
    if (!(s.rest_volume > 0.0))
        throw InvalidInput("the sweep's rest volume is not positive");
    s.keys = std::move(keys);
    return s;
}

int Rig::add_sweep(std::vector<KeyEllipse> keys) {
    if (sweeps.size() >= 1024) throw InvalidInput("a rig holds at most 1024 sweeps");
    sweeps.push_back(make_sweep(std::move(keys), skeleton));
    return static_cast<int>(sweeps.size()) - 1;
}

}  // namespace sd
