#include "deform/sweep_kernel.h"

#include "deform/frame_blend.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <numeric>

namespace sd {

namespace {
constexpr int32_t kBatch = 2048;

/// w (C(u) + R(u) l) for influences [begin, end) of one half-span. Written as one flat loop
/// over arrays with loop-invariant coefficients, no branches: it vectorises.
void evaluate_batch(const HalfSpanKernel& k, int32_t begin, int32_t end, const float* __restrict u_,
                    const float* __restrict w_, const float* __restrict x_, const float* __restrict y_,
                    const float* __restrict z_, const float* __restrict cos_, const float* __restrict sin_,
                    float* __restrict px, float* __restrict py, float* __restrict pz) {
    const HalfSpanKernel c = k;  // locals: no aliasing with the outputs
    for (int32_t i = begin; i < end; ++i) {
        const float u = u_[i];
        const float da = c.da[0] + u * (c.da[1] + u * c.da[2]);
        const float db = c.db[0] + u * (c.db[1] + u * c.db[2]);
        const float lx = x_[i] + da * cos_[i], ly = y_[i] + db * sin_[i], lz = z_[i];
        // R(u) l with Q(u) = (1-u) q0 + u q1 unnormalised: l + s (w (q×l) + q×(q×l)), s = 2/|q|².
        const float qx = c.q0[0] + u * (c.q1[0] - c.q0[0]);
        const float qy = c.q0[1] + u * (c.q1[1] - c.q0[1]);
        const float qz = c.q0[2] + u * (c.q1[2] - c.q0[2]);
        const float qw = c.q0[3] + u * (c.q1[3] - c.q0[3]);
        const float s = 2.0f / (qx * qx + qy * qy + qz * qz + qw * qw);
        const float cx = qy * lz - qz * ly, cy = qz * lx - qx * lz, cz = qx * ly - qy * lx;
        const float ex = qy * cz - qz * cy, ey = qz * cx - qx * cz, ez = qx * cy - qy * cx;
        const float w = w_[i];
        px[i] = w * (c.c[0][0] + u * (c.c[1][0] + u * (c.c[2][0] + u * c.c[3][0])) + lx + s * (qw * cx + ex));
        py[i] = w * (c.c[0][1] + u * (c.c[1][1] + u * (c.c[2][1] + u * c.c[3][1])) + ly + s * (qw * cy + ey));
        pz[i] = w * (c.c[0][2] + u * (c.c[1][2] + u * (c.c[2][2] + u * c.c[3][2])) + lz + s * (qw * cz + ez));
    }
}

/// Influences of frame-blended vertices: the unweighted position C(u) + R(u) l and the
/// rotation R(u) R_rest(u)^-1 as a unit quaternion.
struct FrameSlots {
    const float *u, *x, *y, *z, *cos, *sin, *rx, *ry, *rz, *rw;
    float *px, *py, *pz, *qx, *qy, *qz, *qw;
};

void evaluate_frame_batch(const HalfSpanKernel& c, int32_t begin, int32_t end, const FrameSlots& f) {
    for (int32_t i = begin; i < end; ++i) {
        const float u = f.u[i];
        const float da = c.da[0] + u * (c.da[1] + u * c.da[2]);
        const float db = c.db[0] + u * (c.db[1] + u * c.db[2]);
        const float l[3] = {f.x[i] + da * f.cos[i], f.y[i] + db * f.sin[i], f.z[i]};
        float q[4];
        float n = 0.0f;
        for (int k = 0; k < 4; ++k) {
            q[k] = c.q0[k] + u * (c.q1[k] - c.q0[k]);
            n += q[k] * q[k];
        }
        const float inv = 1.0f / std::sqrt(n);
        for (float& k : q) k *= inv;
        float rl[3];
        rotate_by_unit_quaternion(q, l, rl);
        f.px[i] = c.c[0][0] + u * (c.c[1][0] + u * (c.c[2][0] + u * c.c[3][0])) + rl[0];
        f.py[i] = c.c[0][1] + u * (c.c[1][1] + u * (c.c[2][1] + u * c.c[3][1])) + rl[1];
        f.pz[i] = c.c[0][2] + u * (c.c[1][2] + u * (c.c[2][2] + u * c.c[3][2])) + rl[2];
        // q r, r = Q_rest(u)^-1
        const float rx = f.rx[i], ry = f.ry[i], rz = f.rz[i], rw = f.rw[i];
        f.qx[i] = q[3] * rx + q[0] * rw + q[1] * rz - q[2] * ry;
        f.qy[i] = q[3] * ry - q[0] * rz + q[1] * rw + q[2] * rx;
        f.qz[i] = q[3] * rz + q[0] * ry - q[1] * rx + q[2] * rw;
        f.qw[i] = q[3] * rw - q[0] * rx - q[1] * ry - q[2] * rz;
    }
}

}  // namespace

SweepKernel::SweepKernel(const Binding& b, const std::vector<int>& span_base,
                         const std::vector<std::array<float, 4>>& rest_inverse, const std::vector<uint8_t>& point_sweep,
                         const std::vector<uint8_t>& point_bone) {
    const auto& inf = b.sweep_influences;
    const size_t n = inf.size();
    const int V = b.vertex_count();
    row_blends_.assign(V, 0.0f);
    point_bone_ = point_bone;
    std::vector<uint8_t> blended(n, 0);
    for (int v = 0; v < V; ++v) {
        // Blended as frames: a vertex with a sweep influence and two or more influences that
        // join as frames; its frame share is their weight.
        int frames = 0;
        float share = 0.0f;
        for (uint32_t i = b.sweep_offsets[v]; i < b.sweep_offsets[v + 1]; ++i)
            if (!point_sweep[i]) ++frames, share += inf[i].weight;
        for (uint32_t i = b.bone_offsets[v]; i < b.bone_offsets[v + 1]; ++i)
            if (!point_bone[i]) ++frames, share += b.bone_influences[i].weight;
        const bool blends = frames > 1 && b.sweep_offsets[v + 1] > b.sweep_offsets[v];
        row_blends_[v] = blends ? share : 0.0f;
        for (uint32_t i = b.sweep_offsets[v]; i < b.sweep_offsets[v + 1]; ++i) blended[i] = blends;
    }
    // Sorted by (blended as frames, half-span): each batch is one kind and one half-span.
    std::vector<int32_t> half(n);
    for (size_t i = 0; i < n; ++i)
        half[i] = 2 * (span_base[inf[i].sweep] + inf[i].span) + (inf[i].u < 0.5f ? 0 : 1) + (blended[i] ? 1 << 29 : 0);
    std::vector<uint32_t> order(n);
    std::iota(order.begin(), order.end(), 0u);
    std::stable_sort(order.begin(), order.end(), [&](uint32_t a, uint32_t c) { return half[a] < half[c]; });

    std::vector<uint32_t> slot_of(n);
    for (auto* v :
         {&u_, &w_, &x_, &y_, &z_, &cos_, &sin_, &px_, &py_, &pz_, &rx_, &ry_, &rz_, &rw_, &qx_, &qy_, &qz_, &qw_})
        v->resize(n);
    point_slot_.resize(n);
    for (size_t s = 0; s < n; ++s) {
        const SweepInfluence& f = inf[order[s]];
        slot_of[order[s]] = static_cast<uint32_t>(s);
        u_[s] = f.u;
        w_[s] = f.weight;
        x_[s] = f.local[0];
        y_[s] = f.local[1];
        z_[s] = f.local[2];
        cos_[s] = f.cos_theta;
        sin_[s] = f.sin_theta;
        point_slot_[s] = point_sweep[order[s]];
        const auto& r = rest_inverse[order[s]];
        rx_[s] = r[0];
        ry_[s] = r[1];
        rz_[s] = r[2];
        rw_[s] = r[3];
    }
    for (size_t s = 0; s < n;) {
        const int32_t h = half[order[s]];
        size_t e = s;
        while (e < n && half[order[e]] == h && e - s < static_cast<size_t>(kBatch)) ++e;
        batches_.push_back({h & ((1 << 29) - 1), static_cast<int32_t>(s), static_cast<int32_t>(e), h >= (1 << 29)});
        s = e;
    }
    row_offsets_ = b.sweep_offsets;
    rows_.resize(n);
    for (size_t i = 0; i < n; ++i) rows_[i] = slot_of[i];
}

void SweepKernel::run(const HalfSpanKernel* half_spans, const Affine3x4* bones, const float* bone_rotations,
                      const Binding& b, float* out, float* rotations) {
    const FrameSlots slots{u_.data(),  x_.data(),  y_.data(),  z_.data(),  cos_.data(), sin_.data(),
                           rx_.data(), ry_.data(), rz_.data(), rw_.data(), px_.data(),  py_.data(),
                           pz_.data(), qx_.data(), qy_.data(), qz_.data(), qw_.data()};
    tbb::parallel_for(tbb::blocked_range<size_t>(0, batches_.size()), [&](const tbb::blocked_range<size_t>& r) {
        for (size_t i = r.begin(); i != r.end(); ++i) {
            const Batch& bt = batches_[i];
            if (bt.frames)
                evaluate_frame_batch(half_spans[bt.half_span], bt.begin, bt.end, slots);
            else
                evaluate_batch(half_spans[bt.half_span], bt.begin, bt.end, u_.data(), w_.data(), x_.data(), y_.data(),
                               z_.data(), cos_.data(), sin_.data(), px_.data(), py_.data(), pz_.data());
        }
    });
    const float* rest = b.rest_positions.data();
    tbb::parallel_for(tbb::blocked_range<int>(0, b.vertex_count(), 4096), [&](const tbb::blocked_range<int>& r) {
        for (int v = r.begin(); v != r.end(); ++v) {
            float p[3] = {0.0f, 0.0f, 0.0f};
            if (row_blends_[v] > 0.0f) {
                // Frames blended among themselves, weighted by their share; points added.
                FrameBlend blend(rest + 3 * v);
                float framed_lin[3] = {0.0f, 0.0f, 0.0f};
                for (uint32_t i = row_offsets_[v]; i < row_offsets_[v + 1]; ++i) {
                    const uint32_t s = rows_[i];
                    const float q[4] = {qx_[s], qy_[s], qz_[s], qw_[s]}, at[3] = {px_[s], py_[s], pz_[s]};
                    float* sum = point_slot_[s] ? p : framed_lin;
                    for (int k = 0; k < 3; ++k) sum[k] += w_[s] * at[k];
                    if (!point_slot_[s]) blend.add(w_[s], q, at);
                }
                for (uint32_t i = b.bone_offsets[v]; i < b.bone_offsets[v + 1]; ++i) {
                    const BoneInfluence& in = b.bone_influences[i];
                    float at[3] = {0.0f, 0.0f, 0.0f};
                    bones[in.bone].apply_add(1.0f, rest + 3 * v, at);
                    float* sum = point_bone_[i] ? p : framed_lin;
                    for (int k = 0; k < 3; ++k) sum[k] += in.weight * at[k];
                    if (!point_bone_[i]) blend.add(in.weight, bone_rotations + 4 * in.bone, at);
                }
                float q[4] = {0.0f, 0.0f, 0.0f, 1.0f}, framed[3];
                const float share = row_blends_[v];
                if (blend.apply(framed, q))
                    for (int k = 0; k < 3; ++k) p[k] += share * framed[k];
                else  // the frames cancel: their convex combination
                    for (int k = 0; k < 3; ++k) p[k] += framed_lin[k];
                if (rotations)
                    for (int k = 0; k < 4; ++k) rotations[4 * static_cast<size_t>(v) + k] = q[k];
            } else {
                for (uint32_t i = row_offsets_[v]; i < row_offsets_[v + 1]; ++i) {
                    const uint32_t s = rows_[i];
                    p[0] += px_[s];
                    p[1] += py_[s];
                    p[2] += pz_[s];
                }
                for (uint32_t i = b.bone_offsets[v]; i < b.bone_offsets[v + 1]; ++i)
                    bones[b.bone_influences[i].bone].apply_add(b.bone_influences[i].weight, rest + 3 * v, p);
            }
            out[3 * v] = p[0];
            out[3 * v + 1] = p[1];
            out[3 * v + 2] = p[2];
        }
    });
}

}  // namespace sd
