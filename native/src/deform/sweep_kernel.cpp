#include "deform/sweep_kernel.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
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

}  // namespace

SweepKernel::SweepKernel(const Binding& b, const std::vector<int>& span_base) {
    const auto& inf = b.sweep_influences;
    const size_t n = inf.size();
    std::vector<int32_t> half(n);
    for (size_t i = 0; i < n; ++i) half[i] = 2 * (span_base[inf[i].sweep] + inf[i].span) + (inf[i].u < 0.5f ? 0 : 1);
    std::vector<uint32_t> order(n);
    std::iota(order.begin(), order.end(), 0u);
    std::stable_sort(order.begin(), order.end(), [&](uint32_t a, uint32_t c) { return half[a] < half[c]; });

    std::vector<uint32_t> slot_of(n);
    for (auto* v : {&u_, &w_, &x_, &y_, &z_, &cos_, &sin_, &px_, &py_, &pz_}) v->resize(n);
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
    }
    for (size_t s = 0; s < n;) {
        const int32_t h = half[order[s]];
        size_t e = s;
        while (e < n && half[order[e]] == h && e - s < static_cast<size_t>(kBatch)) ++e;
        batches_.push_back({h, static_cast<int32_t>(s), static_cast<int32_t>(e)});
        s = e;
    }
    row_offsets_ = b.sweep_offsets;
    rows_.resize(n);
    for (size_t i = 0; i < n; ++i) rows_[i] = slot_of[i];
}

void SweepKernel::run(const HalfSpanKernel* half_spans, const Affine3x4* bones, const Binding& b, float* out) {
    tbb::parallel_for(tbb::blocked_range<size_t>(0, batches_.size()), [&](const tbb::blocked_range<size_t>& r) {
        for (size_t i = r.begin(); i != r.end(); ++i) {
            const Batch& bt = batches_[i];
            evaluate_batch(half_spans[bt.half_span], bt.begin, bt.end, u_.data(), w_.data(), x_.data(), y_.data(),
                           z_.data(), cos_.data(), sin_.data(), px_.data(), py_.data(), pz_.data());
        }
    });
    const float* rest = b.rest_positions.data();
    tbb::parallel_for(tbb::blocked_range<int>(0, b.vertex_count(), 4096), [&](const tbb::blocked_range<int>& r) {
        for (int v = r.begin(); v != r.end(); ++v) {
            float p[3] = {0.0f, 0.0f, 0.0f};
            for (uint32_t i = row_offsets_[v]; i < row_offsets_[v + 1]; ++i) {
                const uint32_t s = rows_[i];
                p[0] += px_[s];
                p[1] += py_[s];
                p[2] += pz_[s];
            }
            for (uint32_t i = b.bone_offsets[v]; i < b.bone_offsets[v + 1]; ++i)
                bones[b.bone_influences[i].bone].apply_add(b.bone_influences[i].weight, rest + 3 * v, p);
            out[3 * v] = p[0];
            out[3 * v + 1] = p[1];
            out[3 * v + 2] = p[2];
        }
    });
}

}  // namespace sd
