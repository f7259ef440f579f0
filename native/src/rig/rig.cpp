#include "rig/rig.h"

#include "rig/key_correction.h"
#include "rig/trunk.h"

#include <algorithm>
#include <cmath>

namespace sd {

namespace {
std::string key_name(size_t k) { return "key ellipse " + std::to_string(k); }
bool finite(const dvec3& v) { return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z); }
}  // namespace

namespace {

/// A bone's link: towards its only child's head when it has one child, else along the bone. A
/// glTF rig has no tails, and importers point every bone one way whatever the limb does
/// (CesiumMan's all point +x, its legs run down -z), which made a knee's bend read as a twist.
/// For a Blender chain of connected bones it is the same direction.
dvec3 link_axis(const Skeleton& skeleton, int bone) {
    int only = -1, children = 0;
    for (int b = 0; b < skeleton.bone_count(); ++b)
        if (skeleton.parents[b] == bone) {
            only = b;
            ++children;
        }
    const dvec3 along = skeleton.tails[bone] - skeleton.heads[bone];
    if (children == 1) {
        const dvec3 to_child = skeleton.heads[only] - skeleton.heads[bone];
        if (glm::length(to_child) > 1e-6 * glm::length(along)) return glm::normalize(to_child);
    }
    return glm::normalize(along);
}

/// The joint of every key (see KeyJoint).
std::vector<KeyJoint> key_joints(const std::vector<KeyEllipse>& keys, const std::vector<double>& knots,
                                 const Skeleton& skeleton) {
    const int K = static_cast<int>(keys.size());
    std::vector<KeyJoint> joints(K);
    for (int k = 0; k < K; ++k) {
        int nearest = -1;
        for (int j = 0; j < K; ++j)
            if (keys[j].is_joint_key() &&
                (nearest < 0 || std::abs(knots[j] - knots[k]) < std::abs(knots[nearest] - knots[k])))
                nearest = j;
        KeyJoint& joint = joints[k];
        if (nearest >= 0) {
            joint.parent = keys[nearest].joint_parent;
            joint.child = keys[nearest].bone;
        } else {
            joint.parent = skeleton.parents[keys[k].bone];
            joint.child = keys[k].bone;
        }
        joint.child_axis = link_axis(skeleton, joint.child);
        if (joint.parent >= 0) {
            joint.parent_axis = link_axis(skeleton, joint.parent);
            joint.rest_angle = angle_between(joint.parent_axis, joint.child_axis);
        } else {
            joint.parent_axis = joint.child_axis;
            joint.rest_angle = 0.0;
        }
    }
    return joints;
}

/// Throws unless a(t), b(t) stay > 0 between the keys for these key values.
void check_half_axes(const Sweep& s, const std::vector<double>& a, const std::vector<double>& b,
                     const std::string& what) {
    for (int span = 0; span < s.span_count(); ++span)
        for (int i = 0; i <= 16; ++i) {
            const double u = i / 16.0;
            if (!(s.rest_half_axes.basis.evaluate(a.data(), span, u) > 0.0) ||
                !(s.rest_half_axes.basis.evaluate(b.data(), span, u) > 0.0))
                throw InvalidInput(what + ": the interpolated half-axes become <= 0 between key ellipses " +
                                   std::to_string(span) + " and " + std::to_string(span + 1));
        }
}

void check_correction(const Sweep& s, int k, const KeyCorrection& c) {
    const KeyEllipse& e = s.keys[k];
    const std::string what = "correction of key ellipse " + std::to_string(k) + " at angle " + std::to_string(c.angle);
    if (!std::isfinite(c.angle) || c.angle < 0.0 || c.angle > M_PI + 1e-9)
        throw InvalidInput(what + ": the angle must be in [0, pi]");
    if (!finite(c.delta_center) || glm::length(c.delta_center) > 10.0 * std::max(e.a, e.b))
        throw InvalidInput(what + ": the center offset must be finite and at most 10 x the larger half-axis (" +
                           std::to_string(10.0 * std::max(e.a, e.b)) + ")");
    if (!finite(c.delta_rotation) || glm::length(c.delta_rotation) > 0.5 * M_PI + 1e-9)
        throw InvalidInput(what + ": the rotation must be finite and at most pi/2");
    for (double f : {c.scale_a, c.scale_b})
        if (!std::isfinite(f) || f < 0.1 || f > 10.0)
            throw InvalidInput(what + ": the half-axis scales must be in [0.1, 10]");
    // The sample's own half-axes (other keys at rest) must give a valid a(t), b(t).
    std::vector<double> a = s.rest_half_axes.a, b = s.rest_half_axes.b;
    a[k] *= c.scale_a;
    b[k] *= c.scale_b;
    check_half_axes(s, a, b, what);
}

}  // namespace

void set_sweep_corrections(Sweep& s, std::vector<std::vector<KeyCorrection>> per_key) {
    const int K = s.key_count();
    if (static_cast<int>(per_key.size()) != K) throw InvalidInput("one list of corrections per key ellipse is needed");
    bool any = false;
    for (int k = 0; k < K; ++k) {
        auto& cs = per_key[k];
        if (static_cast<int>(cs.size()) > kMaxCorrectionsPerKey)
            throw InvalidInput("key ellipse " + std::to_string(k) + " has more than " +
                               std::to_string(kMaxCorrectionsPerKey) + " corrections");
        for (const KeyCorrection& c : cs) check_correction(s, k, c);
        std::stable_sort(cs.begin(), cs.end(),
                         [](const KeyCorrection& x, const KeyCorrection& y) { return x.angle < y.angle; });
        any = any || !cs.empty();
    }
    // The rest pose with its corrections (those at the rest angles): valid, and its volume.
    std::vector<dvec3> centers;
    std::vector<dquat> rotations;
    std::vector<double> a = s.rest_half_axes.a, b = s.rest_half_axes.b;
    bool at_rest = false;
    for (int k = 0; k < K; ++k) {
        centers.push_back(s.keys[k].center);
        rotations.push_back(s.keys[k].orientation);
        const double rest = s.joints[k].rest_angle;
        const KeyCorrectionValue v = correction_at(per_key[k], rest, rest);
        if (v.is_identity()) continue;
        at_rest = true;
        apply_correction(v, centers.back(), rotations.back(), a[k], b[k]);
    }
    double v0 = s.rest_volume;
    if (at_rest) {
        const SweepGeometry g(centers, rotations);
        for (int k = 0; k < K; ++k) {
            const int span = k < K - 1 ? k : k - 1;
            const double u = k < K - 1 ? 0.0 : 1.0;
            if (!(glm::dot(glm::mat3_cast(rotations[k])[2], g.tangent(span, u)) > 0.0))
                throw InvalidInput("with its corrections at the rest angle, the normal of key ellipse " +
                                   std::to_string(k) + " no longer points along the sweep");
        }
        check_half_axes(s, a, b, "the corrections at the rest angles");
        v0 = sweep_volume(s.quadrature, volume_density(s.quadrature, g), s.rest_half_axes.a.data(),
                          s.rest_half_axes.b.data());
        if (!(v0 > 0.0))
            throw InvalidInput("with its corrections at the rest angles the sweep's rest volume is not positive");
    }
    for (int k = 0; k < K; ++k) s.keys[k].corrections = std::move(per_key[k]);
    s.corrected_rest_volume = v0;
    s.has_corrections = any;
}

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
            throw InvalidInput(key_name(k) + ": orientation is not a unit quaternion (|q| = " + std::to_string(qn) +
                               ")");
        if (!(e.a > 0.0) || !(e.b > 0.0) || !std::isfinite(e.a) || !std::isfinite(e.b))
            throw InvalidInput(key_name(k) + ": half-axes must be finite and > 0");
        if (e.bone < 0 || e.bone >= B)
            throw InvalidInput(key_name(k) + ": bone " + std::to_string(e.bone) + " is out of range 0.." +
                               std::to_string(B - 1));
        if (e.joint_parent < -1 || e.joint_parent >= B || e.joint_parent == e.bone)
            throw InvalidInput(key_name(k) + ": joint parent " + std::to_string(e.joint_parent) +
                               " is out of range or equals its bone");
        for (double f : {e.swing_fraction, e.twist_fraction})
            if (!(f >= 0.0 && f <= 1.0)) throw InvalidInput(key_name(k) + ": swing/twist fractions must be in [0, 1]");
        if (!(e.twist_spread >= 1.0 && e.twist_spread <= 2.0))
            throw InvalidInput(key_name(k) + ": the twist spread must be in [1, 2]");
        if (e.twist_direction != dvec3(0.0) && !(std::abs(glm::length(e.twist_direction) - 1.0) <= 1e-6))
            throw InvalidInput(key_name(k) + ": the twist direction must be zero or a unit vector");
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
            throw InvalidInput(key_name(k) +
                               ": its normal (third column) must point along "
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
                throw InvalidInput("between key ellipses " + std::to_string(span) + " and " + std::to_string(span + 1) +
                                   " the interpolated half-axes become <= 0; "
                                   "neighbouring half-axes differ too much");
        }
    s.quadrature = VolumeQuadrature(s.rest_half_axes.basis);
    s.control_keys = volume_control_keys(is_joint);
    s.rest_volume = sweep_volume(s.quadrature, volume_density(s.quadrature, s.rest_geometry), s.rest_half_axes.a.data(),
                                 s.rest_half_axes.b.data());
    if (!(s.rest_volume > 0.0)) throw InvalidInput("the sweep's rest volume is not positive");
    s.joints = key_joints(keys, s.rest_geometry.knots(), skeleton);
    s.motions = key_motions(keys, skeleton);
    for (const KeyMotion& m : s.motions) s.bends_smoothly = s.bends_smoothly || !m.blend.empty();
    s.corrected_rest_volume = s.rest_volume;
    std::vector<std::vector<KeyCorrection>> corrections(keys.size());
    bool corrected = false;
    for (size_t k = 0; k < keys.size(); ++k) {
        corrections[k] = std::move(keys[k].corrections);
        keys[k].corrections.clear();
        corrected = corrected || !corrections[k].empty();
    }
    s.keys = std::move(keys);
    if (corrected) set_sweep_corrections(s, std::move(corrections));
    return s;
}

int Rig::add_sweep(std::vector<KeyEllipse> keys) {
    if (sweeps.size() >= 1024) throw InvalidInput("a rig holds at most 1024 sweeps");
    sweeps.push_back(make_sweep(std::move(keys), skeleton));
    set_shoulder_motions(*this);
    return static_cast<int>(sweeps.size()) - 1;
}

void Rig::set_corrections(const std::vector<CorrectionRecord>& records) {
    std::vector<std::vector<std::vector<KeyCorrection>>> lists(sweeps.size());
    for (size_t s = 0; s < sweeps.size(); ++s) lists[s].resize(sweeps[s].keys.size());
    for (const CorrectionRecord& r : records) {
        if (r.sweep < 0 || r.sweep >= static_cast<int>(sweeps.size()))
            throw InvalidInput("correction for sweep " + std::to_string(r.sweep) + ", which does not exist");
        if (r.key < 0 || r.key >= sweeps[r.sweep].key_count())
            throw InvalidInput("correction for key ellipse " + std::to_string(r.key) + " of sweep " +
                               std::to_string(r.sweep) + ", which does not exist");
        lists[r.sweep][r.key].push_back(r.correction);
    }
    std::vector<Sweep> updated = sweeps;
    for (size_t s = 0; s < sweeps.size(); ++s) {
        try {
            set_sweep_corrections(updated[s], std::move(lists[s]));
        } catch (const InvalidInput& e) {
            throw InvalidInput("sweep " + std::to_string(s) + ": " + e.what());
        }
    }
    sweeps = std::move(updated);
}

void Rig::set_key_corrections(int sweep, int key, std::vector<KeyCorrection> list) {
    if (sweep < 0 || sweep >= static_cast<int>(sweeps.size()))
        throw InvalidInput("sweep index " + std::to_string(sweep) + " is out of range");
    Sweep& s = sweeps[sweep];
    if (key < 0 || key >= s.key_count()) throw InvalidInput("key index " + std::to_string(key) + " is out of range");
    std::vector<std::vector<KeyCorrection>> per_key;
    for (const KeyEllipse& e : s.keys) per_key.push_back(e.corrections);
    per_key[key] = std::move(list);
    set_sweep_corrections(s, std::move(per_key));  // leaves s unchanged if it throws
}

std::vector<CorrectionRecord> Rig::corrections() const {
    std::vector<CorrectionRecord> out;
    for (size_t s = 0; s < sweeps.size(); ++s)
        for (int k = 0; k < sweeps[s].key_count(); ++k)
            for (const KeyCorrection& c : sweeps[s].keys[k].corrections) out.push_back({static_cast<int>(s), k, c});
    return out;
}

}  // namespace sd
