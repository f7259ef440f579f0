#include "deform.h"

#include "key_pose.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

namespace sd {

Deformer::Deformer(Rig rig, Binding binding) : rig_(std::move(rig)), binding_(std::move(binding)) {
    binding_.check_structure();
    binding_.check_against(rig_);
    int base = 0;
    for (const Sweep& s : rig_.sweeps) {
        span_base_.push_back(base);
        base += s.span_count();
    }
    spans_.resize(base);
    for (const SweepInfluence& inf : binding_.sweep_influences)
        kernel_span_.push_back(span_base_[inf.sweep] + inf.span);
    volume_offsets_.assign(rig_.sweeps.size(), 0.0);
    volume_before.assign(rig_.sweeps.size(), 0.0);
    volume_after.assign(rig_.sweeps.size(), 0.0);
    volume_iterations.assign(rig_.sweeps.size(), 0);
}

void Deformer::set_volume_preservation(bool enabled, double strength) {
    if (!(strength >= 0.0 && strength <= 1.0))
        throw InvalidInput("volume preservation strength must be in [0, 1]");
    volume_enabled_ = enabled;
    volume_strength_ = strength;
}

void Deformer::set_volume_offsets(const std::vector<double>& offsets) {
    if (offsets.size() != rig_.sweeps.size())
        throw InvalidInput("one volume offset per sweep is needed");
    for (size_t s = 0; s < offsets.size(); ++s)
        if (!std::isfinite(offsets[s]) || !(offsets[s] < rig_.sweeps[s].rest_volume))
            throw InvalidInput("volume offset of sweep " + std::to_string(s) +
                               " must be finite and smaller than its rest volume");
    volume_offsets_ = offsets;
}

void Deformer::prepare_sweeps(const SkeletonPose& pose) {
    std::vector<dvec3> centers;
    std::vector<dquat> rotations;
    for (size_t si = 0; si < rig_.sweeps.size(); ++si) {
        const Sweep& s = rig_.sweeps[si];
        pose_keys(s, pose, centers, rotations);
        const SweepGeometry g(centers, rotations);

        // Volume control (Sect. 4.4) on the key half-axes.
        std::vector<double> a = s.rest_half_axes.a, b = s.rest_half_axes.b;
        const std::vector<double> density = volume_density(s.quadrature, g);
        if (volume_enabled_ && volume_strength_ > 0.0) {
            const double before = sweep_volume(s.quadrature, density, a.data(), b.data());
            const double target = before + volume_strength_ *
                                               (s.rest_volume - volume_offsets_[si] - before);
            const VolumeControlResult r =
                control_volume(s.quadrature, density, s.control_keys, target, a, b);
            volume_before[si] = r.before;
            volume_after[si] = r.after;
            volume_iterations[si] = r.iterations;
        } else {
            volume_before[si] = volume_after[si] = sweep_volume(s.quadrature, density, a.data(), b.data());
            volume_iterations[si] = 0;
        }

        const int K = s.key_count();
        std::vector<double> da(K), db(K);
        for (int k = 0; k < K; ++k) {
            da[k] = a[k] - s.rest_half_axes.a[k];
            db[k] = b[k] - s.rest_half_axes.b[k];
        }
        const auto& q = g.key_rotations();
        for (int span = 0; span < s.span_count(); ++span) {
            SpanKernel& kern = spans_[span_base_[si] + span];
            const CubicSpan& c = g.center_span(span);
            for (int i = 0; i < 4; ++i)
                for (int j = 0; j < 3; ++j) kern.c[i][j] = static_cast<float>(c.c[i][j]);
            const dquat &q0 = q[span], &q1 = q[span + 1];
            const double v0[4] = {q0.x, q0.y, q0.z, q0.w}, v1[4] = {q1.x, q1.y, q1.z, q1.w};
            for (int i = 0; i < 4; ++i) {
                kern.q0[i] = static_cast<float>(v0[i]);
                kern.q1[i] = static_cast<float>(v1[i]);
            }
            for (int half = 0; half < 2; ++half)
                for (int r = 0; r < 3; ++r) {
                    double sa = 0.0, sb = 0.0;
                    for (int k = 0; k < K; ++k) {
                        const double phi = s.rest_half_axes.basis.coefficients(span, half, k)[r];
                        sa += da[k] * phi;
                        sb += db[k] * phi;
                    }
                    kern.da[half][r] = static_cast<float>(sa);
                    kern.db[half][r] = static_cast<float>(sb);
                }
        }
    }
}

namespace {

/// One sweep influence of one vertex: w * (C(u) + R(u) (x + Δa cosθ, y + Δb sinθ, z)).
inline void add_sweep_influence(const SpanKernel& k, const SweepInfluence& inf, float* p) {
    const float u = inf.u;
    const int h = u < 0.5f ? 0 : 1;
    const float da = k.da[h][0] + u * (k.da[h][1] + u * k.da[h][2]);
    const float db = k.db[h][0] + u * (k.db[h][1] + u * k.db[h][2]);
    const float lx = inf.local[0] + da * inf.cos_theta;
    const float ly = inf.local[1] + db * inf.sin_theta;
    const float lz = inf.local[2];
    // Q(u) = (1-u) q0 + u q1, applied without normalising: v + s (w (q×v) + q×(q×v)), s = 2/|q|^2.
    const float qx = k.q0[0] + u * (k.q1[0] - k.q0[0]);
    const float qy = k.q0[1] + u * (k.q1[1] - k.q0[1]);
    const float qz = k.q0[2] + u * (k.q1[2] - k.q0[2]);
    const float qw = k.q0[3] + u * (k.q1[3] - k.q0[3]);
    const float s = 2.0f / (qx * qx + qy * qy + qz * qz + qw * qw);
    const float cx = qy * lz - qz * ly, cy = qz * lx - qx * lz, cz = qx * ly - qy * lx;
    const float ex = qy * cz - qz * cy, ey = qz * cx - qx * cz, ez = qx * cy - qy * cx;
    const float w = inf.weight;
    for (int i = 0; i < 3; ++i) {
        const float center = k.c[0][i] + u * (k.c[1][i] + u * (k.c[2][i] + u * k.c[3][i]));
        const float local = i == 0 ? lx : (i == 1 ? ly : lz);
        const float cross = i == 0 ? cx : (i == 1 ? cy : cz);
        const float cross2 = i == 0 ? ex : (i == 1 ? ey : ez);
        p[i] += w * (center + local + s * (qw * cross + cross2));
    }
}

}  // namespace

void Deformer::deform(const float* pose, float* out) {
    pose_.set(rig_.skeleton, pose);
    prepare_sweeps(pose_);
    bones_ = bone_affines(pose_);

    const Binding& b = binding_;
    const SweepInfluence* sweep_inf = b.sweep_influences.data();
    const int32_t* kspan = kernel_span_.data();
    const SpanKernel* spans = spans_.data();
    const BoneInfluence* bone_inf = b.bone_influences.data();
    const Affine3x4* bones = bones_.data();
    const float* rest = b.rest_positions.data();
    tbb::parallel_for(tbb::blocked_range<int>(0, b.vertex_count(), 2048),
                      [&](const tbb::blocked_range<int>& r) {
        for (int v = r.begin(); v != r.end(); ++v) {
            float p[3] = {0.0f, 0.0f, 0.0f};
            for (uint32_t i = b.sweep_offsets[v]; i < b.sweep_offsets[v + 1]; ++i)
                add_sweep_influence(spans[kspan[i]], sweep_inf[i], p);
            for (uint32_t i = b.bone_offsets[v]; i < b.bone_offsets[v + 1]; ++i)
                bones[bone_inf[i].bone].apply_add(bone_inf[i].weight, rest + 3 * v, p);
            out[3 * v] = p[0];
            out[3 * v + 1] = p[1];
            out[3 * v + 2] = p[2];
        }
    });
}

}  // namespace sd
