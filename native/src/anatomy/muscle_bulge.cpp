#include "anatomy/muscle_bulge.h"

#include "math/smoothstep.h"
#include "rig/key_pose.h"
#include "rig/sweep.h"

#include <algorithm>
#include <cmath>

namespace sd::anatomy {

namespace {

/// A plateau on [0, 1] whose edges rise over `falloff` of the extent.
double plateau(double x, double falloff) {
    if (x <= 0.0 || x >= 1.0) return 0.0;
    return smoothstep01(x / falloff) * smoothstep01((1.0 - x) / falloff);
}

}  // namespace

double MuscleBulge::activation(double flexion, double full_flexion) { return smoothstep01(flexion / full_flexion); }

MuscleBulge::MuscleBulge(MuscleSpec spec, const Rig& rig, const SkinParts& parts, double falloff)
    : spec_(std::move(spec)) {
    if (spec_.sweep < 0 || spec_.sweep >= static_cast<int>(rig.sweeps.size()))
        throw InvalidInput("a muscle's sweep is out of range");
    if (!(spec_.t1 > spec_.t0)) throw InvalidInput("a muscle's parameter range is empty");
    set_falloff(rig, parts, falloff);
}

void MuscleBulge::set_falloff(const Rig& rig, const SkinParts& parts, double falloff) {
    if (!(falloff >= 0.05 && falloff <= 0.5)) throw InvalidInput("bulge falloff must be in [0.05, 0.5]");
    falloff_ = falloff;
    vertices_.clear();
    span_.clear();
    u_.clear();
    weight_.clear();
    dir_.clear();
    const Sweep& s = rig.sweeps[spec_.sweep];
    const SweepGeometry& g = s.rest_geometry;
    for (int v = 0; v < parts.vertex_count(); ++v) {
        if (parts.sweep[v] != spec_.sweep) continue;
        const double x = (parts.t[v] - spec_.t0) / (spec_.t1 - spec_.t0);
        const double wt = plateau(x, falloff);
        if (wt <= 0.0) continue;
        const float* l = &parts.local[3 * static_cast<size_t>(v)];
        const double radius = std::hypot(l[0], l[1]);
        if (!(radius > 0.0)) continue;
        // The sector's middle in this vertex's rest ellipse frame.
        const dmat3 r = g.rotation(parts.span[v], parts.u[v]);
        const dvec3 side = glm::transpose(r) * spec_.side;
        const double theta_c = std::atan2(side.y, side.x), theta = std::atan2(l[1], l[0]);
        double dt = std::remainder(theta - theta_c, 2.0 * M_PI);
        const double wa = plateau(0.5 + 0.5 * dt / spec_.half_width, falloff);
        if (wa <= 0.0) continue;
        vertices_.push_back(v);
        span_.push_back(parts.span[v]);
        u_.push_back(parts.u[v]);
        weight_.push_back(static_cast<float>(wt * wa * parts.weight[v] * radius));
        dir_.push_back(static_cast<float>(l[0] / radius));
        dir_.push_back(static_cast<float>(l[1] / radius));
    }
}

double MuscleBulge::apply(const Rig& rig, const SkeletonPose& pose, double flexion, double strength, float* p,
                          VertexEdits& edits) const {
    const double act = activation(flexion, spec_.full_flexion);
    if (!(act > 0.0) || !(strength > 0.0) || vertices_.empty()) return 0.0;
    std::vector<dvec3> centers;
    std::vector<dquat> rotations;
    pose_keys(rig.sweeps[spec_.sweep], pose, centers, rotations);
    const SweepGeometry g(centers, rotations);
    const double k = strength * act;
    double largest = 0.0;
    for (size_t i = 0; i < vertices_.size(); ++i) {
        const dvec3 radial =
            rotate_unnormalized(g.raw_rotation(span_[i], u_[i]), dvec3(dir_[2 * i], dir_[2 * i + 1], 0.0));
        const dvec3 delta = k * weight_[i] * radial;
        const int v = vertices_[i];
        edits.touch(v, p, spec_.joint);
        for (int c = 0; c < 3; ++c) p[3 * static_cast<size_t>(v) + c] += static_cast<float>(delta[c]);
        largest = std::max(largest, glm::length(delta));
    }
    return largest;
}

}  // namespace sd::anatomy
