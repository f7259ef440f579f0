// Shared by the fuzz targets: the synthetic arm of the native tests, built through the ABI,
// and a little reader that turns fuzzer bytes into numbers.
#pragma once

#include "sweepdeform/sweepdeform.h"

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <vector>

namespace sdfuzz {

/// Consumes typed values from the fuzzer's bytes; past the end it yields zeros.
class Bytes {
public:
    Bytes(const uint8_t* data, size_t size) : p_(data), n_(size) {}
    template <class T>
    T take() {
        T v{};
        const size_t k = n_ < sizeof(T) ? n_ : sizeof(T);
        if (k) std::memcpy(&v, p_, k);
        p_ += k;
        n_ -= k;
        return v;
    }
    size_t left() const { return n_; }

private:
    const uint8_t* p_;
    size_t n_;
};

/// Three bones along +x and one sweep of seven keys (see tests/support/test_arm.h), half-axes
/// a x b, centred `off` off the bones (a thick one, 0.6 x 0.5 on links 1 long, is a trunk).
struct Arm {
    int32_t parents[3] = {-1, 0, 1};
    float rest[48] = {};
    float heads[9] = {0, 0, 0, 1, 0, 0, 2, 0, 0}, tails[9] = {1, 0, 0, 2, 0, 0, 2.3f, 0, 0};
    sd_rig* rig = nullptr;
    float a = 0.1f, b = 0.07f;

    explicit Arm(float half_a = 0.1f, float half_b = 0.07f, float off = 0.01f) : a(half_a), b(half_b) {
        for (int bone = 0; bone < 3; ++bone) {
            for (int i = 0; i < 4; ++i) rest[16 * bone + 5 * i] = 1.0f;
            rest[16 * bone + 12] = heads[3 * bone];
        }
        float centers[21], orientations[28], half_axes[14], fractions[14];
        int32_t bones[7] = {0, 0, 0, 1, 1, 1, 2}, joint_parents[7] = {-1, -1, -1, 0, -1, -1, 1};
        for (int k = 0; k < 7; ++k) {
            // Off the bones (by default a centimetre, as a limb's sections are: a twist then turns
            // each key's offset about its bone between keys, twisted_trajectory.h, not only its frame).
            centers[3 * k] = k / 3.0f;
            centers[3 * k + 1] = off;
            centers[3 * k + 2] = 0.0f;
            for (int i = 0; i < 4; ++i) orientations[4 * k + i] = 0.5f;
            half_axes[2 * k] = a;
            half_axes[2 * k + 1] = b;
            fractions[2 * k] = 0.5f;
            fractions[2 * k + 1] = k == 6 ? 1.0f : 0.5f;
        }
        if (sd_rig_create(3, parents, rest, heads, tails, &rig) != SD_OK ||
            sd_rig_add_sweep(rig, 7, centers, orientations, half_axes, bones, joint_parents, fractions, nullptr) !=
                SD_OK)
            __builtin_trap();
    }
    ~Arm() { sd_rig_destroy(rig); }

    /// The rig's blob (sd_rig_serialize).
    std::vector<uint8_t> rig_blob() const {
        int64_t n = 0;
        sd_rig_serialize(rig, nullptr, 0, &n);
        std::vector<uint8_t> b(static_cast<size_t>(n));
        if (sd_rig_serialize(rig, b.data(), n, &n) != SD_OK) __builtin_trap();
        return b;
    }
    /// The blob of bind()'s binding.
    std::vector<uint8_t> binding_blob() const {
        sd_binding* h = bind();
        int64_t n = 0;
        sd_binding_serialize(h, nullptr, 0, &n);
        std::vector<uint8_t> b(static_cast<size_t>(n));
        if (sd_binding_serialize(h, b.data(), n, &n) != SD_OK) __builtin_trap();
        sd_binding_destroy(h);
        return b;
    }
    /// Triangles of bind()'s ring mesh (11 rings of 8 points, quads split).
    static std::vector<int32_t> ring_triangles() {
        std::vector<int32_t> t;
        for (int r = 0; r < 10; ++r)
            for (int s = 0; s < 8; ++s) {
                const int32_t a = 8 * r + s, b = 8 * r + (s + 1) % 8, c = a + 8, d = b + 8;
                t.insert(t.end(), {a, b, d, a, d, c});
            }
        return t;
    }

    /// A ring mesh around the sweep, 11 rings of 8 points with its half-axes (the triangles:
    /// ring_triangles()), bound to it (for targets that need a binding).
    sd_binding* bind() const {
        std::vector<float> mesh;
        for (int k = 0; k < 11; ++k)
            for (int s = 0; s < 8; ++s)
                mesh.insert(mesh.end(), {k / 5.0f, a * std::cos(s * 0.785f), b * std::sin(s * 0.785f)});
        std::vector<int32_t> ids(88, 0);
        std::vector<float> w(88, 1.0f);
        sd_binding* out = nullptr;
        if (sd_bind(rig, 88, mesh.data(), 1, ids.data(), w.data(), 0, nullptr, nullptr, &out) != SD_OK)
            __builtin_trap();
        return out;
    }
};

/// The arm bent by `angle` radians about +z at the elbow (bone 1's head); bone 2 follows.
inline std::vector<float> bent_pose(float angle) {
    const float c = std::cos(angle), s = std::sin(angle);
    std::vector<float> p(48, 0.0f);
    for (int b = 0; b < 3; ++b) p[16 * b + 15] = 1.0f;
    p[0] = p[5] = p[10] = 1.0f;  // bone 0 at rest
    for (int b = 1; b < 3; ++b) {
        float* m = &p[16 * b];
        m[0] = c, m[1] = s, m[4] = -s, m[5] = c, m[10] = 1.0f;  // columns: rotation about z
        const float along = b == 1 ? 0.0f : 1.0f;               // bone 2's head 1 along bone 1
        m[12] = 1.0f + c * along, m[13] = s * along, m[14] = 0.0f;
    }
    return p;
}

/// Every output must be finite when a call succeeded.
inline void require_finite(const float* p, size_t n) {
    for (size_t i = 0; i < n; ++i)
        if (!std::isfinite(p[i])) __builtin_trap();
}

}  // namespace sdfuzz
