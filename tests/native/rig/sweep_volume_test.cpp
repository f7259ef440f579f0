// Sect. 3.1: V = ∫ π a(t) b(t) <N(t), C'(t)> dt, against closed forms.
#include "test_arm.h"
#include "rig/volume.h"

#include <gtest/gtest.h>

namespace sd {
namespace {

TEST(SweepVolume, StraightEllipticCylinderIsPiABL) {
    const test::Arm arm;  // a = 0.1, b = 0.07, length 2
    const double expected = M_PI * test::Arm::kA * test::Arm::kB * 2.0;
    EXPECT_NEAR(arm.rig.sweeps[0].rest_volume / expected, 1.0, 1e-6);
}

/// Volume of a quarter torus section (ellipses: a radial, b along the axis, swept around the
/// z axis at radius R) through K key ellipses, relative to Pappus' π a b · R · angle.
double quarter_torus_ratio(int K) {
    const double R = 1.0, a = 0.2, b = 0.15, angle = M_PI / 2;
    Rig rig;
    rig.skeleton = Skeleton::build({-1}, {dmat4(1.0)}, {dvec3(0)}, {dvec3(0, 0, 1)});
    std::vector<KeyEllipse> keys;
    for (int k = 0; k < K; ++k) {
        const double phi = angle * k / (K - 1);
        const dvec3 radial(std::cos(phi), std::sin(phi), 0), tangent(-std::sin(phi), std::cos(phi), 0);
        KeyEllipse e;
        e.center = R * radial;
        e.orientation = glm::quat_cast(dmat3(radial, dvec3(0, 0, -1), tangent));
        e.a = a;
        e.b = b;
        e.bone = 0;
        keys.push_back(e);
    }
    rig.add_sweep(keys);
    return rig.sweeps[0].rest_volume / (M_PI * a * b * R * angle);
}

TEST(SweepVolume, CircularArcMatchesPappus) {
    // The cubic through points on the circle only approximates the circle (its natural end
    // conditions most of all), so the error is the curve's, and it shrinks with more keys.
    const double e5 = std::abs(quarter_torus_ratio(5) - 1.0);
    const double e17 = std::abs(quarter_torus_ratio(17) - 1.0);
    const double e65 = std::abs(quarter_torus_ratio(65) - 1.0);
    std::printf("Pappus relative error: 5 keys %.2e, 17 keys %.2e, 65 keys %.2e\n", e5, e17, e65);
    EXPECT_LT(e5, 3e-3);
    EXPECT_LT(e17, 5e-5);
    EXPECT_LT(e65, 1e-6);
    EXPECT_LT(e65, e17);
}

TEST(SweepVolume, GradientMatchesFiniteDifferences) {
    const test::Arm arm;
    const Sweep& s = arm.rig.sweeps[0];
    const auto density = volume_density(s.quadrature, s.rest_geometry);
    std::vector<double> a = s.rest_half_axes.a, b = s.rest_half_axes.b;
    a[3] *= 1.3;  // make the sweep non-uniform
    std::vector<double> ga(a.size()), gb(b.size());
    sweep_volume(s.quadrature, density, a.data(), b.data(), ga.data(), gb.data());
    for (size_t k = 0; k < a.size(); ++k) {
        const double h = 1e-6;
        std::vector<double> ap = a, am = a;
        ap[k] += h;
        am[k] -= h;
        const double fd = (sweep_volume(s.quadrature, density, ap.data(), b.data()) -
                           sweep_volume(s.quadrature, density, am.data(), b.data())) /
                          (2 * h);
        EXPECT_NEAR(ga[k], fd, 1e-7) << "key " << k;
    }
}

TEST(VolumeControl, SpreadsTheGrowthOverTheJointAndItsNeighbours) {
    // The arm has one interior joint key (the elbow, key 3). Asked for 4 % more volume, the
    // controller reaches it by scaling the elbow key and its two neighbours alike; the paper's
    // order (the joint alone for two iterations) put it all into the elbow key, a bulb that
    // pushed a real elbow's skin to 1.67x its rest distance from the bone.
    const test::Arm arm;
    const Sweep& s = arm.rig.sweeps[0];
    const VolumeForm form(s.quadrature, volume_density(s.quadrature, s.rest_geometry));
    std::vector<double> a = s.rest_half_axes.a, b = s.rest_half_axes.b;
    ASSERT_EQ(s.control_keys.joints, std::vector<int>{3});
    const double target = 1.04 * s.rest_volume;
    const VolumeControlResult r = control_volume(form, s.control_keys, target, a, b);
    EXPECT_LE(std::abs(r.after - target) / target, 2e-4);
    double largest = 0.0;
    for (size_t k = 0; k < a.size(); ++k) {
        const double scale = std::sqrt(a[k] * b[k] / (s.rest_half_axes.a[k] * s.rest_half_axes.b[k]));
        largest = std::max(largest, scale);
    }
    for (int k : {2, 4}) EXPECT_GT(std::sqrt(a[k] * b[k] / (s.rest_half_axes.a[k] * s.rest_half_axes.b[k])), 1.03) << k;
    EXPECT_LT(largest, 1.08);
}

}  // namespace
}  // namespace sd
