// Anatomy: joint set-up — adding a joint, its collision regions and automatic effects (bone
// proxy, muscle), its settings and proxy, and the folding and protrusion parameters derived
// from them. The per-frame pipeline is in anatomy.cpp, the volume restoration in
// volume_restoration.cpp.
#include "anatomy/anatomy.h"
#include "anatomy/anatomy_internal.h"

#include <algorithm>
#include <cmath>
#include <string>

namespace sd::anatomy {

int Anatomy::add_joint(int lower_bone, JointKind kind, const dvec3* flexion_direction) {
    for (const Joint& j : joints_)
        if (j.lower_bone == lower_bone)
            throw InvalidInput("bone " + std::to_string(lower_bone) + " already has a joint");
    joints_.push_back(make_joint(rig_, lower_bone, kind, flexion_direction));
    const int j = joint_count() - 1;
    region_triangles_.emplace_back();
    region_edge_.push_back(0.0);
    try {
        build_regions(j);
        add_automatic_effects(j);
    } catch (...) {
        joints_.pop_back();
        region_triangles_.pop_back();
        region_edge_.pop_back();
        proxies_.erase(
            std::remove_if(proxies_.begin(), proxies_.end(), [&](const BoneProxy& p) { return p.joint() == j; }),
            proxies_.end());
        muscles_.erase(
            std::remove_if(muscles_.begin(), muscles_.end(), [&](const MuscleBulge& m) { return m.spec().joint == j; }),
            muscles_.end());
        throw;
    }
    if (kind != JointKind::Generic) {
        build_sweep_region(joints_[j].sweep);
        build_restore_zone(j);
    }
    collision_dirty_ = true;
    return j;
}

void Anatomy::build_regions(int j) {
    Joint& joint = joints_[j];
    joint.region_radius = joint.settings.region_radius > 0.0 ? joint.settings.region_radius : joint.auto_region_radius;
    const double r = joint.region_radius;
    std::vector<int32_t>& region = region_triangles_[j];
    region.clear();
    double edges = 0.0;
    for (int t = 0; t < mesh_.triangle_count(); ++t) {
        const int32_t* tv = mesh_.triangle(t);
        bool inside = true;
        for (int k = 0; k < 3 && inside; ++k) inside = glm::length(point(rest_.data(), tv[k]) - joint.center) <= r;
        if (!inside) continue;
        region.push_back(t);
        edges += glm::length(point(rest_.data(), tv[1]) - point(rest_.data(), tv[0]));
    }
    region_edge_[j] = region.empty() ? 0.0 : edges / static_cast<double>(region.size());
    // Keep the pieces that matter: fragments the ball's border cuts off (a few triangles
    // hanging on by an edge) only cost the collision query its normal-cone culling.
    std::vector<int32_t> in(mesh_.triangle_count(), 0);
    for (int32_t t : region) in[t] = 1;
    std::vector<int32_t> kept, component;
    const size_t min_size = std::max<size_t>(16, region.size() / 100);
    for (int32_t seed : region) {
        if (in[seed] != 1) continue;
        component.assign(1, seed);
        in[seed] = 2;
        for (size_t q = 0; q < component.size(); ++q) {
            const int32_t* tv = mesh_.triangle(component[q]);
            for (int k = 0; k < 3; ++k) {
                const int32_t a = tv[k], b = tv[(k + 1) % 3];
                for (uint32_t i = mesh_.vertex_triangle_offsets[a]; i < mesh_.vertex_triangle_offsets[a + 1]; ++i) {
                    const int32_t o = mesh_.vertex_triangles[i];
                    if (in[o] != 1) continue;
                    const int32_t* ov = mesh_.triangle(o);
                    if (ov[0] == b || ov[1] == b || ov[2] == b) {
                        in[o] = 2;
                        component.push_back(o);
                    }
                }
            }
        }
        if (component.size() >= min_size) kept.insert(kept.end(), component.begin(), component.end());
    }
    std::sort(kept.begin(), kept.end());
    region.swap(kept);
}

void Anatomy::add_automatic_effects(int j) {
    const Joint& J = joints_[j];
    if (J.kind == JointKind::Generic) return;
    const bool elbow = J.kind == JointKind::Elbow;

    // ---- the bone proxy: olecranon behind the elbow, patella in front of the knee.
    const dmat3 key_frame = glm::mat3_cast(J.key_ellipse.orientation);
    const dvec3 kn = key_frame[2];
    dvec3 e = -J.flexion_dir;  // extensor side
    e = glm::normalize(e - glm::dot(e, kn) * kn);
    double r_e = J.ellipse_radius(e);
    {
        TriangleBvh bvh;
        bvh.build(mesh_, region_triangles_[j], rest_.data(), 4, false);
        const double o[3] = {J.center.x, J.center.y, J.center.z}, d[3] = {e.x, e.y, e.z};
        double t = 0.0;
        int32_t tri = -1;
        if (bvh.ray_first_hit(rest_.data(), o, d, 3.0 * r_e, &t, &tri) && t > 0.2 * r_e) r_e = t;
    }
    dvec3 along = J.lower_dir - glm::dot(J.lower_dir, e) * e;
    along = glm::length(along) > 1e-9 ? glm::normalize(along) : kn;
    const dvec3 lateral = glm::normalize(glm::cross(along, e));
    const double r_l = J.ellipse_radius(lateral);
    const dmat3 axes(e, lateral, along);
    dvec3 semi, center;
    double fraction;
    if (elbow) {  // the olecranon: the ulna's hook, just proximal of the joint, on the back
        semi = dvec3(0.30 * r_e, 0.35 * r_l, 0.60 * r_e);
        center = J.center + e * (0.92 * r_e - semi.x) - along * (0.15 * r_e);
        fraction = 1.0;
    } else {  // the patella: in front of the knee, gliding with the bisector of the joint
        semi = dvec3(0.25 * r_e, 0.40 * r_l, 0.45 * r_e);
        center = J.center + e * (0.92 * r_e - semi.x);
        fraction = 0.5;
    }
    std::vector<int32_t> candidates;
    const double reach = glm::length(center - J.center) + std::max({semi.x, semi.y, semi.z}) +
                         1.5 * std::max(J.key_ellipse.a, J.key_ellipse.b);
    for (int v = 0; v < mesh_.vertex_count; ++v)
        if ((parts_.part[v] == J.upper_bone || parts_.part[v] == J.lower_bone) &&
            glm::length(point(rest_.data(), v) - J.center) < reach)
            candidates.push_back(v);
    // Shrink towards the joint until the rest skin is outside with a 5 % margin: the rest pose
    // stays exactly as the sweeps make it.
    for (int iter = 0; iter < 40; ++iter) {
        bool inside = false;
        for (int32_t v : candidates) {
            const dvec3 x = glm::transpose(axes) * (point(rest_.data(), v) - center);
            if ((x.x / semi.x) * (x.x / semi.x) + (x.y / semi.y) * (x.y / semi.y) + (x.z / semi.z) * (x.z / semi.z) <
                1.1025) {
                inside = true;
                break;
            }
        }
        if (!inside) break;
        center = J.center + 0.96 * (center - J.center);
        semi *= 0.96;
    }
    BoneProxy proxy(j, fraction, ellipsoid_shape(center, axes, semi, 2), elbow ? "olecranon" : "patella");
    proxy.set_anchor(J.center);
    proxy.set_candidates(candidates);
    // In extension the olecranon sits in its fossa behind the humerus and the patella rests
    // on the femur above the groove, both under thick soft tissue; in flexion they come out
    // under thin skin: the proxy moves out along the extensor side as the joint flexes.
    proxy.set_emergence(e * ((elbow ? 0.1 : 0.45) * r_e),
                        std::max(0.3, glm::radians(elbow ? 135.0 : 110.0) - J.rest_bend));
    proxies_.push_back(std::move(proxy));

    // ---- the muscle: biceps on the front of the upper arm, calf on the back of the shin.
    const Sweep& s = rig_.sweeps[J.sweep];
    const auto& knots = s.rest_geometry.knots();
    MuscleSpec m;
    m.joint = j;
    m.sweep = J.sweep;
    m.side = J.flexion_dir;
    m.half_width = glm::radians(70.0);
    if (elbow) {
        int kp = 0;
        for (int k = J.key - 1; k >= 0; --k)
            if (s.keys[k].is_joint_key()) {
                kp = k;
                break;
            }
        const double t0 = knots[kp], t1 = knots[J.key];
        m.name = "biceps";
        m.t0 = t0 + 0.20 * (t1 - t0);
        m.t1 = t0 + 0.92 * (t1 - t0);
        m.full_flexion = std::max(0.3, glm::radians(110.0) - J.rest_bend);
    } else {
        int kn2 = s.key_count() - 1;
        for (int k = J.key + 1; k < s.key_count(); ++k)
            if (s.keys[k].is_joint_key()) {
                kn2 = k;
                break;
            }
        const double t0 = knots[J.key], t1 = knots[kn2];
        m.name = "calf";
        m.t0 = t0 + 0.08 * (t1 - t0);
        m.t1 = t0 + 0.60 * (t1 - t0);
        m.full_flexion = std::max(0.3, glm::radians(120.0) - J.rest_bend);
    }
    muscles_.emplace_back(m, rig_, parts_, J.settings.bulge_falloff);
}

void Anatomy::set_joint_settings(int j, const JointSettings& s) {
    if (j < 0 || j >= joint_count()) throw InvalidInput("joint " + std::to_string(j) + " is out of range");
    const auto check = [](double v, double lo, double hi, const char* what) {
        if (!(v >= lo && v <= hi) || !std::isfinite(v))
            throw InvalidInput(std::string(what) + " must be in [" + std::to_string(lo) + ", " + std::to_string(hi) +
                               "]");
    };
    check(s.protrusion_strength, 0.0, 2.0, "protrusion strength");
    check(s.bulge_strength, 0.0, 1.0, "bulge strength");
    check(s.bulge_falloff, 0.05, 0.5, "bulge falloff");
    check(s.protrusion_falloff, 0.0, 1e6, "protrusion falloff");
    check(s.folding_falloff, 0.0, 1e6, "folding falloff");
    check(s.folding_margin, 0.0, 1e6, "folding margin");
    check(s.region_radius, 0.0, 1e6, "region radius");
    Joint& joint = joints_[j];
    const JointSettings old = joint.settings;
    joint.settings = s;
    if (s.bulge_falloff != old.bulge_falloff)
        for (MuscleBulge& m : muscles_)
            if (m.spec().joint == j) m.set_falloff(rig_, parts_, s.bulge_falloff);
    if (s.region_radius != old.region_radius) {
        build_regions(j);
        if (joint.kind != JointKind::Generic) {
            restore_zones_[joint.sweep] = RestoreZone{};
            build_restore_zone(j);
        }
        collision_dirty_ = true;
    }
    if (s.folding != old.folding) collision_dirty_ = true;
}

void Anatomy::set_joint_proxy(int j, ProxyShape shape, double fraction) {
    if (j < 0 || j >= joint_count()) throw InvalidInput("joint " + std::to_string(j) + " is out of range");
    const Joint& J = joints_[j];
    BoneProxy proxy(j, fraction, std::move(shape), "user");
    proxy.set_anchor(J.center);
    std::vector<int32_t> candidates;
    const double reach =
        glm::length(proxy.center() - J.center) + proxy.bound() + 1.5 * std::max(J.key_ellipse.a, J.key_ellipse.b);
    for (int v = 0; v < mesh_.vertex_count; ++v)
        if (glm::length(point(rest_.data(), v) - J.center) < reach) candidates.push_back(v);
    proxy.set_candidates(std::move(candidates));
    proxies_.erase(std::remove_if(proxies_.begin(), proxies_.end(), [&](const BoneProxy& p) { return p.joint() == j; }),
                   proxies_.end());
    proxies_.push_back(std::move(proxy));
}

FoldingParams Anatomy::folding_params(int j) const {
    const Joint& J = joints_[j];
    FoldingParams p;
    const double minor = std::min(J.key_ellipse.a, J.key_ellipse.b);
    p.margin =
        J.settings.folding_margin > 0.0 ? J.settings.folding_margin : std::min(0.05 * region_edge_[j], 0.01 * minor);
    p.falloff_radius = J.settings.folding_falloff > 0.0 ? J.settings.folding_falloff : 0.5 * minor;
    // Bent limbs press one link's skin deep into the other's: bisecting planes. Around the
    // generic joints (armpit, groin, neck) contacts are shallow and mostly skin crumpling
    // where two sweeps blend, which relaxing resolves better.
    p.planes = J.kind != JointKind::Generic;
    p.limb_radius = std::max(J.key_ellipse.a, J.key_ellipse.b);
    return p;
}

double Anatomy::protrusion_falloff(int j) const {
    const Joint& J = joints_[j];
    return J.settings.protrusion_falloff > 0.0 ? J.settings.protrusion_falloff
                                               : 0.6 * std::min(J.key_ellipse.a, J.key_ellipse.b);
}

}  // namespace sd::anatomy
