// Blending a vertex's influences as rigid frames (dual quaternions) rather than as points.
//
// Each influence of a vertex V (a sweep's moving ellipse, or a bone) moves V to p_i and turns
// its neighbourhood by q_i; as a rigid map, x -> q_i (x - V) + p_i. Where the q_i agree (one
// sweep, or the rest pose) blending these maps as dual quaternions gives Σ w_i p_i, the
// paper's convex combination (Sect. 3.5). Where they differ — skin shared by the torso and a
// limb at the hip and shoulder, or by a sweep and the bone beyond its end — the convex
// combination of points cuts the chord between the p_i and loses volume as linear blend
// skinning does, while the blended frame turns V along the arc, as Preserve Volume does.
#pragma once

#include <cmath>

namespace sd {

/// q = (x, y, z, w) rotates v: v + 2 w (q×v) + 2 q×(q×v) (q of unit length).
inline void rotate_by_unit_quaternion(const float* q, const float* v, float* out) {
    const float cx = q[1] * v[2] - q[2] * v[1], cy = q[2] * v[0] - q[0] * v[2], cz = q[0] * v[1] - q[1] * v[0];
    const float ex = q[1] * cz - q[2] * cy, ey = q[2] * cx - q[0] * cz, ez = q[0] * cy - q[1] * cx;
    out[0] = v[0] + 2.0f * (q[3] * cx + ex);
    out[1] = v[1] + 2.0f * (q[3] * cy + ey);
    out[2] = v[2] + 2.0f * (q[3] * cz + ez);
}

/// A bone's map as a dual quaternion in armature space, once per frame: its rotation q (the
/// 3x3 part with normalised columns) and ½ (T, 0) q for its translation T. About a vertex V
/// the same map has the dual part d + (q.xyz × V, 0), which is how FrameBlend takes it
/// (add_bone). A bone that scales or shears is not rigid: its vertices use where M V puts
/// them instead (FrameBlend::add).
struct BoneFrame {
    float q[4];
    float d[4];
    bool rigid;
};
BoneFrame bone_frame(const float m[3][4]);

/// Accumulates w × (q, ½ t q), on q's hemisphere of the first frame added (w > 0). Dual quaternion
/// blending does not depend on the coordinates it is done in, so it is done with V at the
/// origin: the map x -> q (x - V) + p is then x -> q x + t with t = p - V, and where the
/// blend puts V is its translation.
class FrameBlend {
public:
    /// @param q  unit rotation of the influence relative to rest; @param t  where it moves V
    ///           (its position minus V's rest position)
    void add(float w, const float* q, const float* t) {
        const float h = 0.5f * w;  // ½ (t, 0) q, weighted
        const float real[4] = {w * q[0], w * q[1], w * q[2], w * q[3]};
        const float dual[4] = {
            h * (t[0] * q[3] + t[1] * q[2] - t[2] * q[1]), h * (-t[0] * q[2] + t[1] * q[3] + t[2] * q[0]),
            h * (t[0] * q[1] - t[1] * q[0] + t[2] * q[3]), -h * (t[0] * q[0] + t[1] * q[1] + t[2] * q[2])};
        add_weighted(real, dual);
    }

    /// The same with w q and ½ w t q already formed (SweepKernel forms them vectorised).
    void add_weighted(const float* real, const float* dual) {
        if (!started_) {
            for (int i = 0; i < 4; ++i) ref_[i] = real[i];
            started_ = true;
        }
        const float sign =
            real[0] * ref_[0] + real[1] * ref_[1] + real[2] * ref_[2] + real[3] * ref_[3] < 0.0f ? -1.0f : 1.0f;
        for (int i = 0; i < 4; ++i) {
            real_[i] += sign * real[i];
            dual_[i] += sign * dual[i];
        }
    }

    /// A rigid bone's frame (bone_frame), weighted, about V.
    void add_bone(float w, const BoneFrame& f, const float* v) {
        const float* u = f.q;
        const float real[4] = {w * f.q[0], w * f.q[1], w * f.q[2], w * f.q[3]};
        const float dual[4] = {w * (f.d[0] + u[1] * v[2] - u[2] * v[1]), w * (f.d[1] + u[2] * v[0] - u[0] * v[2]),
                               w * (f.d[2] + u[0] * v[1] - u[1] * v[0]), w * f.d[3]};
        add_weighted(real, dual);
    }

    /// How far the blended frame moves V, and (if wanted) its unit rotation. False if the
    /// frames cancel (opposite rotations of equal weight): the caller keeps the convex
    /// combination.
    bool apply(float* move, float* rotation = nullptr) const {
        const float n2 = real_[0] * real_[0] + real_[1] * real_[1] + real_[2] * real_[2] + real_[3] * real_[3];
        if (!(n2 > 1e-12f)) return false;
        const float inv = 1.0f / std::sqrt(n2);
        const float c[4] = {real_[0] * inv, real_[1] * inv, real_[2] * inv, real_[3] * inv};
        const float e[4] = {dual_[0] * inv, dual_[1] * inv, dual_[2] * inv, dual_[3] * inv};
        // 2 (e conj(c)).xyz, the translation of the normalised dual quaternion.
        move[0] = 2.0f * (c[3] * e[0] - e[3] * c[0] + c[1] * e[2] - c[2] * e[1]);
        move[1] = 2.0f * (c[3] * e[1] - e[3] * c[1] + c[2] * e[0] - c[0] * e[2]);
        move[2] = 2.0f * (c[3] * e[2] - e[3] * c[2] + c[0] * e[1] - c[1] * e[0]);
        if (rotation)
            for (int i = 0; i < 4; ++i) rotation[i] = c[i];
        return true;
    }

private:
    float ref_[4] = {0, 0, 0, 1};
    float real_[4] = {0, 0, 0, 0};
    float dual_[4] = {0, 0, 0, 0};
    bool started_ = false;
};

}  // namespace sd
