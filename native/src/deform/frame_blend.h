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

// "No iteration's outputs alias another's inputs" for GCC (the release build's compiler; Clang,
// which builds the fuzzers, vectorises behind its runtime checks and warns about the pragma).
#if defined(__GNUC__) && !defined(__clang__)
#define SD_NO_ALIASING _Pragma("GCC ivdep")
#else
#define SD_NO_ALIASING
#endif

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

/// Four floats in one SIMD register (GCC and Clang vector extensions: SSE on x86-64, NEON
/// on ARM, plain scalars elsewhere). A quaternion is one of them.
typedef float Float4 __attribute__((vector_size(16)));

inline Float4 load4(const float* p) {
    Float4 v;
    __builtin_memcpy(&v, p, sizeof v);
    return v;
}
inline Float4 load3(const float* p) { return Float4{p[0], p[1], p[2], 0.0f}; }
inline float dot4(Float4 a, Float4 b) {
    const Float4 m = a * b;
    return (m[0] + m[1]) + (m[2] + m[3]);
}
/// (a.xyz × b.xyz, a.w b.w − a.w b.w = 0)
inline Float4 cross3(Float4 a, Float4 b) {
    const Float4 a1 = __builtin_shufflevector(a, a, 1, 2, 0, 3), a2 = __builtin_shufflevector(a, a, 2, 0, 1, 3);
    const Float4 b1 = __builtin_shufflevector(b, b, 1, 2, 0, 3), b2 = __builtin_shufflevector(b, b, 2, 0, 1, 3);
    return a1 * b2 - a2 * b1;
}

/// Accumulates w × (q, ½ t q), on q's hemisphere of the first frame added (w > 0). Dual quaternion
/// blending does not depend on the coordinates it is done in, so it is done with V at the
/// origin: the map x -> q (x - V) + p is then x -> q x + t with t = p - V, and where the
/// blend puts V is its translation. Each quaternion is one Float4: a blended vertex is the
/// kernel's most expensive one, and in scalars this was 40 % of a frame.
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
        add_weighted(load4(real), load4(dual));
    }

    /// The same with w q and ½ w t q already formed (SweepKernel forms them vectorised).
    void add_weighted(const float* real, const float* dual) { add_weighted(load4(real), load4(dual)); }

    void add_weighted(Float4 real, Float4 dual) {
        if (!started_) {
            ref_ = real;
            started_ = true;
        }
        const float sign = dot4(real, ref_) < 0.0f ? -1.0f : 1.0f;
        real_ += sign * real;
        dual_ += sign * dual;
    }

    /// A rigid bone's frame (bone_frame), weighted, about V: dual part d + (q.xyz × V, 0).
    void add_bone(float w, const BoneFrame& f, const float* v) {
        const Float4 q = load4(f.q);
        add_weighted(w * q, w * (load4(f.d) + cross3(q, load3(v))));
    }

    /// The sums so far: Σ w q and Σ ½ w t q (on the first frame's hemisphere).
    Float4 real() const { return real_; }
    Float4 dual() const { return dual_; }

private:
    Float4 ref_ = {0, 0, 0, 1};
    Float4 real_ = {0, 0, 0, 0};
    Float4 dual_ = {0, 0, 0, 0};
    bool started_ = false;
};

/// Many vertices' blended frames (FrameBlend sums), as planes of floats (structure of arrays),
/// normalised and applied: each vertex's position is share × (V + how far the blended frame
/// moves V). A flat loop over independent vertices: it vectorises, and the square root
/// and division of each vertex no longer sit in one long scalar chain.
struct BlendedFrames {
    const float* real[4];  // Σ w q, x y z w
    const float* dual[4];  // Σ ½ w t q
    const float* rest[3];  // V
    const float* share;    // the frames' share of the vertex's weight
    float* position[3];    // out: the vertex
    float* norm2;          // out: |Σ w q|²; at most 1e-12 where the frames cancel (opposite
                           // rotations of equal weight: the caller keeps the convex combination)
    float* turn[4];        // out: the blended unit rotation (with J)
};

inline void apply_blended_frames(const BlendedFrames& f, int begin, int end) {
    const float* __restrict rx = f.real[0], * __restrict ry = f.real[1], * __restrict rz = f.real[2], * __restrict rw = f.real[3];
    const float* __restrict dx = f.dual[0], * __restrict dy = f.dual[1], * __restrict dz = f.dual[2], * __restrict dw = f.dual[3];
    const float* __restrict vx = f.rest[0], * __restrict vy = f.rest[1], * __restrict vz = f.rest[2], * __restrict share = f.share;
    float* __restrict px = f.position[0], * __restrict py = f.position[1], * __restrict pz = f.position[2];
    float* __restrict n2_ = f.norm2, * __restrict tx = f.turn[0], * __restrict ty = f.turn[1], * __restrict tz = f.turn[2], * __restrict tw = f.turn[3];
    SD_NO_ALIASING
    for (int k = begin; k < end; ++k) {
        const float n2 = rx[k] * rx[k] + ry[k] * ry[k] + rz[k] * rz[k] + rw[k] * rw[k];
        // No comparison (GCC does not vectorise a select on floats), no division by zero: the
        // outputs of a vertex whose frames cancel are not used (norm2 tells the caller).
        const float inv = 1.0f / std::sqrt(n2 + 1e-30f);
        const float cx = rx[k] * inv, cy = ry[k] * inv, cz = rz[k] * inv, cw = rw[k] * inv;
        const float ex = dx[k] * inv, ey = dy[k] * inv, ez = dz[k] * inv, ew = dw[k] * inv;
        // 2 (e conj(c)).xyz = 2 (c.w e.xyz − e.w c.xyz + c.xyz × e.xyz): the normalised dual
        // quaternion's translation, how far the blended frame moves V.
        const float mx = 2.0f * (cw * ex - ew * cx + (cy * ez - cz * ey));
        const float my = 2.0f * (cw * ey - ew * cy + (cz * ex - cx * ez));
        const float mz = 2.0f * (cw * ez - ew * cz + (cx * ey - cy * ex));
        const float s = share[k];
        px[k] = s * (vx[k] + mx);
        py[k] = s * (vy[k] + my);
        pz[k] = s * (vz[k] + mz);
        n2_[k] = n2;
        tx[k] = cx;
        ty[k] = cy;
        tz[k] = cz;
        tw[k] = cw;
    }
}

}  // namespace sd
