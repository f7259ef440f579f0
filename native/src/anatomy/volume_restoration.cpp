// Anatomy: volume restoration — the skin of each sweep that owns an elbow or a knee held at
// its rest volume by a push of a zone around the joint (anatomy.h). Called from the per-frame
// pipeline in anatomy.cpp.
#include "anatomy/anatomy.h"
#include "anatomy/anatomy_internal.h"

#include "rig/key_pose.h"

#include <algorithm>
#include <cmath>

namespace sd::anatomy {

namespace {

// The restoration trims the push when the skin's volume is off by more than this share of its
// rest volume.
constexpr double kTrimTolerance = 0.002;

}  // namespace

void Anatomy::build_sweep_region(int s) {
    if (!sweep_regions_[s].triangles().empty()) return;
    std::vector<int32_t> tris;
    for (int t = 0; t < mesh_.triangle_count(); ++t) {
        const int32_t* tv = mesh_.triangle(t);
        if (parts_.sweep[tv[0]] == s && parts_.sweep[tv[1]] == s && parts_.sweep[tv[2]] == s) tris.push_back(t);
    }
    if (tris.empty()) return;
    sweep_regions_[s] = ClosedRegion(mesh_, std::move(tris));
    sweep_region_rest_[s] = sweep_regions_[s].volume(rest_.data());
}

void Anatomy::build_restore_zone(int j) {
    const Joint& J = joints_[j];
    RestoreZone& z = restore_zones_[J.sweep];
    if (!z.vertex.empty()) return;  // one zone per sweep (one elbow per arm, one knee per leg)
    const Sweep& s = rig_.sweeps[J.sweep];
    const double R = J.region_radius;
    // Rest vertex areas and normals (area vectors / 3).
    std::vector<dvec3> area(mesh_.vertex_count, dvec3(0.0));
    for (int t = 0; t < mesh_.triangle_count(); ++t) {
        const int32_t* tv = mesh_.triangle(t);
        const dvec3 a = glm::cross(point(rest_.data(), tv[1]) - point(rest_.data(), tv[0]),
                                   point(rest_.data(), tv[2]) - point(rest_.data(), tv[0])) /
                        6.0;
        for (int k = 0; k < 3; ++k) area[tv[k]] += a;
    }
    for (int v = 0; v < mesh_.vertex_count; ++v) {
        if (parts_.sweep[v] != J.sweep) continue;
        const double d = glm::length(point(rest_.data(), v) - J.center);
        if (!(d < R)) continue;
        const float* l = &parts_.local[3 * static_cast<size_t>(v)];
        const double radius = std::hypot(l[0], l[1]);
        if (!(radius > 0.0)) continue;
        const dvec3 radial =
            s.rest_geometry.rotation(parts_.span[v], parts_.u[v]) * dvec3(l[0] / radius, l[1] / radius, 0.0);
        // Smooth in the distance from the joint; around the limb on the extensor half only,
        // growing towards the back: away from the crease, so it makes no new contact there.
        const double q = d / R;
        const double c = glm::dot(radial, J.flexion_dir);
        const double w = (1.0 - q * q) * (1.0 - q * q) * std::max(0.0, -c) * parts_.weight[v];
        if (!(w > 1e-4)) continue;
        z.vertex.push_back(v);
        z.span.push_back(parts_.span[v]);
        z.u.push_back(parts_.u[v]);
        z.dir.push_back(static_cast<float>(l[0] / radius));
        z.dir.push_back(static_cast<float>(l[1] / radius));
        z.weight.push_back(static_cast<float>(w));
        z.rate += w * glm::dot(area[v], radial);
    }
    z.limit = 1.5 * std::max(J.key_ellipse.a, J.key_ellipse.b);
    z.joint = j;
}

double Anatomy::restore_push(const SkeletonPose& pose, float* p) {
    double added = 0.0;
    for (size_t s = 0; s < restore_zones_.size(); ++s) {
        RestoreZone& z = restore_zones_[s];
        if (z.vertex.empty() || z.height == 0.0 || !any_effect(joints_[z.joint].settings)) continue;
        zone_directions(static_cast<int>(s), pose);
        push_zone(z, z.height, p, nullptr);
        added += z.height * z.rate;
    }
    return added;
}

double Anatomy::restore_trim(const SkeletonPose& pose, float* p) {
    double added = 0.0;
    for (size_t s = 0; s < restore_zones_.size(); ++s) {
        RestoreZone& z = restore_zones_[s];
        if (z.vertex.empty() || !(z.rate > 0.0)) continue;
        if (!any_effect(joints_[z.joint].settings)) {
            z.height = 0.0;
            continue;
        }
        const double deficit = sweep_region_rest_[s] - sweep_regions_[s].volume(p);
        // A deficit this small is left (to the next frame's push): trimming it would cost a
        // re-check of the zone's skin for nothing visible.
        if (std::abs(deficit) < kTrimTolerance * sweep_region_rest_[s]) continue;
        // The volume one unit of push adds to the skin as it is now (first order: each
        // vertex's share of its triangles' area vectors along its push).
        zone_directions(static_cast<int>(s), pose);
        double rate = 0.0;
        for (size_t i = 0; i < z.vertex.size(); ++i) {
            const int32_t v = z.vertex[i];
            dvec3 area(0.0);
            for (uint32_t k = mesh_.vertex_triangle_offsets[v]; k < mesh_.vertex_triangle_offsets[v + 1]; ++k) {
                const int32_t* tv = mesh_.triangle(mesh_.vertex_triangles[k]);
                area += glm::cross(point(p, tv[1]) - point(p, tv[0]), point(p, tv[2]) - point(p, tv[0]));
            }
            rate += static_cast<double>(z.weight[i]) * glm::dot(area, zone_radial_[i]) / 6.0;
        }
        if (!(rate > 0.0)) continue;
        const double height = std::clamp(z.height + deficit / rate, -z.limit, z.limit);
        const double dh = height - z.height;
        z.height = height;  // where the next frame's push starts
        if (dh == 0.0) continue;
        push_zone(z, dh, p, &moved_);
        added += dh * rate;
    }
    return added;
}

void Anatomy::zone_directions(int s, const SkeletonPose& pose) {
    const RestoreZone& z = restore_zones_[s];
    pose_keys(rig_.sweeps[s], pose, zone_centers_, zone_rotations_);
    const SweepGeometry g(zone_centers_, zone_rotations_);
    zone_radial_.resize(z.vertex.size());
    for (size_t i = 0; i < z.vertex.size(); ++i)
        zone_radial_[i] =
            rotate_unnormalized(g.raw_rotation(z.span[i], z.u[i]), dvec3(z.dir[2 * i], z.dir[2 * i + 1], 0.0));
}

void Anatomy::push_zone(const RestoreZone& z, double height, float* p, std::vector<int32_t>* moved) {
    for (size_t i = 0; i < z.vertex.size(); ++i) {
        const dvec3 delta = height * static_cast<double>(z.weight[i]) * zone_radial_[i];
        const int32_t v = z.vertex[i];
        edits_.touch(v, p, z.joint);
        if (moved) moved->push_back(v);
        for (int k = 0; k < 3; ++k) p[3 * static_cast<size_t>(v) + k] += static_cast<float>(delta[k]);
    }
}

double Anatomy::sweep_skin_volume(int s, const float* positions) const {
    return sweep_regions_.at(s).volume(positions);
}

double Anatomy::sweep_skin_rest_volume(int s) const { return sweep_region_rest_.at(s); }

}  // namespace sd::anatomy
