#include "anatomy/anatomy.h"

#include "key_pose.h"

#include <glm/gtc/matrix_transform.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <string>

namespace sd::anatomy {

namespace {

using Clock = std::chrono::steady_clock;

// Folding: the first passes fold contacts between parts against bisecting planes; after
// them (and for crumpled skin within one part all along) the left-over pairs' neighbourhood
// (1.5 mean rest edge lengths of the collision regions) is relaxed with four Laplacian passes.
constexpr int kPlanePasses = 2, kRelaxPasses = 4;

// Volume feedback: share of the change of I_C passed on per frame, and the largest offset
// (share of the sweep's rest volume).
constexpr double kFeedbackGain = 0.6, kMaxOffset = 0.15;
// The restoration trims the push when the skin's volume is off by more than this share of its
// rest volume.
constexpr double kTrimTolerance = 0.002;
double ms_since(Clock::time_point t) { return std::chrono::duration<double, std::milli>(Clock::now() - t).count(); }

bool any_effect(const JointSettings& s) { return s.folding || s.protrusion || s.bulge; }

dvec3 point(const float* p, int v) {
    return dvec3(p[3 * static_cast<size_t>(v)], p[3 * static_cast<size_t>(v) + 1], p[3 * static_cast<size_t>(v) + 2]);
}

}  // namespace

Anatomy::Anatomy(const Rig& rig, const Binding& binding, const int32_t* triangles, int triangle_count)
    : rig_(rig) {
    binding.check_structure();
    binding.check_against(rig_);
    rest_ = binding.rest_positions;
    const int V = binding.vertex_count();
    mesh_ = MeshTopology::build(V, triangles, triangle_count, rest_.data());
    parts_ = SkinParts::from_binding(rig_, binding);
    offsets_.assign(rig_.sweeps.size(), 0.0);
    applied_.assign(rig_.sweeps.size(), 0.0);
    sweep_regions_.resize(rig_.sweeps.size());
    restore_zones_.resize(rig_.sweeps.size());
    sweep_region_rest_.assign(rig_.sweeps.size(), 0.0);
    backend_ = make_cpu_collision_backend();
    checker_ = make_cpu_collision_backend(CpuCollisionOptions{false, 8, true});
    edits_.reset(V);
    falloff_.reset(V);
    triangle_stamp_.assign(mesh_.triangle_count(), 0);
    triangle_joint_.assign(mesh_.triangle_count(), -1);
}

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
        proxies_.erase(std::remove_if(proxies_.begin(), proxies_.end(), [&](const BoneProxy& p) { return p.joint() == j; }), proxies_.end());
        muscles_.erase(std::remove_if(muscles_.begin(), muscles_.end(), [&](const MuscleBulge& m) { return m.spec().joint == j; }), muscles_.end());
        throw;
    }
    if (kind != JointKind::Generic) {
        build_sweep_region(joints_[j].sweep);
        build_restore_zone(j);
    }
    collision_dirty_ = true;
    return j;
}

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
                                   point(rest_.data(), tv[2]) - point(rest_.data(), tv[0])) / 6.0;
        for (int k = 0; k < 3; ++k) area[tv[k]] += a;
    }
    for (int v = 0; v < mesh_.vertex_count; ++v) {
        if (parts_.sweep[v] != J.sweep) continue;
        const double d = glm::length(point(rest_.data(), v) - J.center);
        if (!(d < R)) continue;
        const float* l = &parts_.local[3 * static_cast<size_t>(v)];
        const double radius = std::hypot(l[0], l[1]);
        if (!(radius > 0.0)) continue;
        const dvec3 radial = s.rest_geometry.rotation(parts_.span[v], parts_.u[v]) * dvec3(l[0] / radius, l[1] / radius, 0.0);
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
        zone_radial_[i] = rotate_unnormalized(g.raw_rotation(z.span[i], z.u[i]), dvec3(z.dir[2 * i], z.dir[2 * i + 1], 0.0));
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
            if ((x.x / semi.x) * (x.x / semi.x) + (x.y / semi.y) * (x.y / semi.y) + (x.z / semi.z) * (x.z / semi.z) < 1.1025) {
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
    proxy.set_emergence(e * ((elbow ? 0.3 : 0.45) * r_e), std::max(0.3, glm::radians(elbow ? 135.0 : 110.0) - J.rest_bend));
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
            throw InvalidInput(std::string(what) + " must be in [" + std::to_string(lo) + ", " + std::to_string(hi) + "]");
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
    const double reach = glm::length(proxy.center() - J.center) + proxy.bound() +
                         1.5 * std::max(J.key_ellipse.a, J.key_ellipse.b);
    for (int v = 0; v < mesh_.vertex_count; ++v)
        if (glm::length(point(rest_.data(), v) - J.center) < reach) candidates.push_back(v);
    proxy.set_candidates(std::move(candidates));
    proxies_.erase(std::remove_if(proxies_.begin(), proxies_.end(), [&](const BoneProxy& p) { return p.joint() == j; }),
                   proxies_.end());
    proxies_.push_back(std::move(proxy));
}

void Anatomy::set_collision_backend(std::unique_ptr<CollisionBackend> backend) {
    if (!backend) throw InvalidInput("collision backend is null");
    backend_ = std::move(backend);
    collision_dirty_ = true;
}

void Anatomy::set_folding_iterations(int n) {
    if (n < 1 || n > 64) throw InvalidInput("folding iterations must be in 1..64");
    folding_iterations_ = n;
}

void Anatomy::rebuild_collision_set() {
    collision_set_.clear();
    std::fill(triangle_joint_.begin(), triangle_joint_.end(), -1);
    std::vector<double> best(mesh_.triangle_count(), 1e300);
    for (int j = 0; j < joint_count(); ++j) {
        if (!joints_[j].settings.folding) continue;
        for (int32_t t : region_triangles_[j]) {
            const int32_t* tv = mesh_.triangle(t);
            const dvec3 c = (point(rest_.data(), tv[0]) + point(rest_.data(), tv[1]) + point(rest_.data(), tv[2])) / 3.0;
            const double d = glm::length(c - joints_[j].center) / joints_[j].region_radius;
            if (triangle_joint_[t] < 0) collision_set_.push_back(t);
            if (d < best[t]) {
                best[t] = d;
                triangle_joint_[t] = j;
            }
        }
    }
    std::sort(collision_set_.begin(), collision_set_.end());
    double edges = 0.0;
    for (int32_t t : collision_set_) {
        const int32_t* tv = mesh_.triangle(t);
        edges += glm::length(point(rest_.data(), tv[1]) - point(rest_.data(), tv[0]));
    }
    relax_radius_ = collision_set_.empty() ? 0.0 : 1.5 * edges / static_cast<double>(collision_set_.size());
    backend_->set_triangles(mesh_, collision_set_, rest_.data());
    checker_->set_triangles(mesh_, collision_set_, rest_.data());
    collision_dirty_ = false;
}

FoldingParams Anatomy::folding_params(int j) const {
    const Joint& J = joints_[j];
    FoldingParams p;
    const double minor = std::min(J.key_ellipse.a, J.key_ellipse.b);
    p.margin = J.settings.folding_margin > 0.0 ? J.settings.folding_margin
                                               : std::min(0.05 * region_edge_[j], 0.01 * minor);
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

void Anatomy::apply(const SkeletonPose& pose, float* p, Deformer* deformer) {
    if (deformer && (deformer->vertex_count() != vertex_count() || deformer->rig().sweeps.size() != rig_.sweeps.size()))
        throw InvalidInput("the deformer was made for another rig or mesh");
    stats_ = AnatomyStats{};
    stats_.passes = 1;
    const auto t0 = Clock::now();
    apply_pass(pose, p);
    if (deformer) feed(*deformer);
    stats_.ms_total = ms_since(t0);
}

void Anatomy::feed(Deformer& d) {
    std::vector<double> o(offsets_.size(), 0.0);
    if (feedback_ != VolumeFeedback::Off)
        for (size_t s = 0; s < o.size(); ++s) {
            const double cap = kMaxOffset * rig_.sweeps[s].rest_volume;
            o[s] = std::clamp(offsets_[s], -cap, cap);
        }
    d.set_volume_offsets(o);
    applied_ = o;
}

void Anatomy::effects_change(const std::vector<JointPose>& jp, std::vector<double>& change) {
    // The signed-volume change of every triangle around a moved vertex, per sweep (a
    // triangle counts for the sweep most of its vertices are on), taken from the posed joint
    // centre of the joint that moved it.
    change.assign(rig_.sweeps.size(), 0.0);
    const float* p = current_;
    ++stamp_;
    for (int32_t v : edits_.list()) {
        const int owner = edits_.owner(v);
        const dvec3 o3 = owner >= 0 ? jp[owner].center : point(p, v);
        const double o[3] = {o3.x, o3.y, o3.z};
        for (uint32_t i = mesh_.vertex_triangle_offsets[v]; i < mesh_.vertex_triangle_offsets[v + 1]; ++i) {
            const int32_t tri = mesh_.vertex_triangles[i];
            if (triangle_stamp_[tri] == stamp_) continue;
            triangle_stamp_[tri] = stamp_;
            const int32_t* tv = mesh_.triangle(tri);
            const float* before[3];
            for (int k = 0; k < 3; ++k) before[k] = edits_.moved(tv[k]) ? edits_.before(tv[k]) : p + 3 * static_cast<size_t>(tv[k]);
            const double dv = signed_volume(p + 3 * static_cast<size_t>(tv[0]), p + 3 * static_cast<size_t>(tv[1]),
                                            p + 3 * static_cast<size_t>(tv[2]), o) -
                              signed_volume(before[0], before[1], before[2], o);
            const int32_t s0 = parts_.sweep[tv[0]], s1 = parts_.sweep[tv[1]], s2 = parts_.sweep[tv[2]];
            const int32_t sw = (s1 == s2) ? s1 : s0;
            if (sw >= 0) change[sw] += dv;
        }
    }
}

void Anatomy::apply_pass(const SkeletonPose& pose, float* p) {
    current_ = p;
    if (collision_dirty_) rebuild_collision_set();
    edits_.clear();
    const int B = rig_.skeleton.bone_count();
    std::vector<dvec3> reference(B);
    for (int b = 0; b < B; ++b)
        reference[b] = dvec3(pose.deform[b] * dvec4(0.5 * (rig_.skeleton.heads[b] + rig_.skeleton.tails[b]), 1.0));
    std::vector<JointPose> jp(joints_.size());
    for (int j = 0; j < joint_count(); ++j) jp[j] = pose_joint(joints_[j], pose);

    // Muscle bulge.
    auto t = Clock::now();
    for (const MuscleBulge& m : muscles_) {
        const Joint& J = joints_[m.spec().joint];
        if (!J.settings.bulge) continue;
        stats_.max_bulge = std::max(stats_.max_bulge, m.apply(rig_, pose, jp[m.spec().joint].flexion,
                                                              J.settings.bulge_strength, p, edits_));
    }
    stats_.bulge_vertices = static_cast<int>(edits_.list().size());
    stats_.ms_bulge += ms_since(t);

    // Bone protrusion.
    t = Clock::now();
    std::vector<int32_t> sources;
    std::vector<dvec3> deltas;
    for (const BoneProxy& proxy : proxies_) {
        const int j = proxy.joint();
        const Joint& J = joints_[j];
        if (!J.settings.protrusion || !(J.settings.protrusion_strength > 0.0)) continue;
        sources.clear();
        deltas.clear();
        const dvec3 out_by = proxy.emergence() * MuscleBulge::activation(jp[j].flexion, proxy.emergence_full_flexion());
        const double largest = proxy.push(jp[j].fractional(proxy.fraction()) * glm::translate(dmat4(1.0), out_by), p,
                                          J.settings.protrusion_strength, sources, deltas);
        if (sources.empty()) continue;
        stats_.max_protrusion = std::max(stats_.max_protrusion, largest);
        stats_.protrusion_vertices += static_cast<int>(sources.size());
        stats_.falloff_vertices += falloff_.apply(mesh_, sources, deltas, protrusion_falloff(j), nullptr, nullptr,
                                                  p, edits_, j);
    }
    stats_.ms_protrusion += ms_since(t);

    // The volume bulge and protrusion added (before anything else moves).
    t = Clock::now();
    effects_change(jp, early_change_);
    // The volume restoration's push (its height set by the frames before), ahead of the
    // collision detection, so that folding handles whatever contact it makes.
    if (restore_) stats_.restored_volume = restore_push(pose, p);
    stats_.ms_volume += ms_since(t);

    // Collision detection, then folding until no pair is left.
    t = Clock::now();
    pairs_.clear();
    stats_.collision_triangles = static_cast<int>(collision_set_.size());
    if (!collision_set_.empty()) {
        backend_->find_pairs(p, pairs_);
        stats_.triangle_tests += backend_->last_stats().triangle_tests;
    }
    stats_.pairs_before = static_cast<int>(pairs_.size());
    stats_.ms_first_detection += ms_since(t);
    stats_.ms_collision += ms_since(t);
    std::vector<FoldingParams> params(joints_.size());
    for (int j = 0; j < joint_count(); ++j) params[j] = folding_params(j);
    stats_.folding_iterations = 0;
    const auto detect_changed = [&]() {
        // What changed: the triangles of the pairs and those around every moved vertex.
        ++stamp_;
        changed_.clear();
        const auto mark = [&](int32_t tri) {
            if (triangle_stamp_[tri] == stamp_) return;
            triangle_stamp_[tri] = stamp_;
            changed_.push_back(tri);
        };
        for (const TrianglePair& pr : pairs_) {
            mark(pr.a);
            mark(pr.b);
        }
        for (int32_t v : moved_)
            for (uint32_t i = mesh_.vertex_triangle_offsets[v]; i < mesh_.vertex_triangle_offsets[v + 1]; ++i)
                mark(mesh_.vertex_triangles[i]);
        const auto tc = Clock::now();
        if (!changed_.empty() && !collision_set_.empty()) {
            backend_->find_pairs_touching(p, changed_, pairs_);
            ++stats_.rechecks;
            stats_.rechecked_triangles += static_cast<long>(changed_.size());
            stats_.triangle_tests += backend_->last_stats().triangle_tests;
        }
        stats_.ms_collision += ms_since(tc);
    };
    const auto fold_until_clean = [&]() {
        for (int pass = 0; !pairs_.empty() && pass < folding_iterations_; ++pass) {
        t = Clock::now();
        moved_.clear();
        // Contacts between parts fold against bisecting planes (the first passes); skin that
        // crumpled within one part, and whatever the planes leave, is relaxed.
        single_part_.clear();
        if (pass < kPlanePasses) {
            const FoldingStats fs = folding_.fold(mesh_, parts_, pairs_, reference, triangle_joint_, params, p,
                                                  edits_, falloff_, &moved_, &single_part_);
            stats_.folding_regions += fs.regions;
            stats_.folding_vertices += fs.pulled;
            stats_.falloff_vertices += fs.falloff;
            stats_.max_fold_depth = std::max(stats_.max_fold_depth, fs.max_depth);
        } else {
            single_part_ = pairs_;
        }
        if (!single_part_.empty())
            stats_.relaxed_vertices += folding_.relax(mesh_, parts_, single_part_, relax_radius_, kRelaxPasses, p,
                                                      edits_, triangle_joint_, &moved_);
        ++stats_.folding_iterations;
        stats_.ms_folding += ms_since(t);
        detect_changed();
        }
    };
    fold_until_clean();
    if (restore_) {
        // The restoration's trim: the skin's volume as folding left it, corrected in this
        // frame by the push on the extensor side; then whatever contact that makes is folded.
        t = Clock::now();
        moved_.clear();
        stats_.restored_volume += restore_trim(pose, p);
        stats_.ms_volume += ms_since(t);
        if (!moved_.empty()) {
            detect_changed();
            fold_until_clean();
        }
    }
    stats_.pairs_after = static_cast<int>(pairs_.size());

    // Volume: what the folding changed (the bulge's and protrusion's share was taken above).
    t = Clock::now();
    // What everything changed is needed for I_C only without the restoration (which keeps
    // folding's share out of I_C); with it the figure reports bulge and protrusion.
    if (!restore_) {
        effects_change(jp, total_change_);
        for (double dv : total_change_) stats_.effects_volume += dv;
    } else {
        for (double dv : early_change_) stats_.effects_volume += dv;
    }
    // I_C for the controller: the volume bulge, protrusion and folding added (the paper). With
    // the restoration on, folding's loss is given back locally instead — around the crease,
    // where the squeezed flesh goes — since the controller would inflate the joint key, which
    // only deepens the contact and buries the bone points. Approached with a gain below 1 and
    // bounded.
    for (size_t s = 0; s < offsets_.size(); ++s) {
        const double ic = restore_ ? early_change_[s] : total_change_[s];
        const double cap = kMaxOffset * rig_.sweeps[s].rest_volume;
        offsets_[s] = std::clamp(applied_[s] + kFeedbackGain * (ic - applied_[s]), -cap, cap);
    }
    for (double dv : offsets_) stats_.volume_change += dv;
    stats_.ms_volume += ms_since(t);
}

void Anatomy::deform(Deformer& d, const float* pose, float* out) {
    // The passes set the deformer's volume offsets and deform: kept together, and this
    // anatomy's own per-frame state with them, against another thread using the same deformer.
    const auto guard = d.lock();
    if (d.vertex_count() != vertex_count() || d.rig().sweeps.size() != rig_.sweeps.size() ||
        d.rig().skeleton.bone_count() != rig_.skeleton.bone_count())
        throw InvalidInput("the deformer was made for another rig or mesh");
    stats_ = AnatomyStats{};
    const auto t0 = Clock::now();
    pose_.set(rig_.skeleton, pose);
    const int passes = feedback_ == VolumeFeedback::InFrame ? 2 : 1;
    if (feedback_ != VolumeFeedback::NextFrame) {
        applied_.assign(rig_.sweeps.size(), 0.0);
        d.set_volume_offsets(applied_);
    }
    // Two passes in one frame start from nothing: the frame depends on its pose only.
    if (feedback_ == VolumeFeedback::InFrame)
        for (RestoreZone& z : restore_zones_) z.height = 0.0;
    for (int pass = 0; pass < passes; ++pass) {
        auto t = Clock::now();
        d.deform(pose, out);
        stats_.ms_sweeps += ms_since(t);
        apply_pass(pose_, out);
        if (feedback_ != VolumeFeedback::Off) feed(d);
    }
    stats_.passes = passes;
    stats_.ms_total = ms_since(t0);
}

int Anatomy::count_intersections(const float* positions, std::vector<TrianglePair>* pairs) {
    if (collision_dirty_) rebuild_collision_set();
    std::vector<TrianglePair> local;
    std::vector<TrianglePair>& out = pairs ? *pairs : local;
    checker_->find_pairs(positions, out);
    return static_cast<int>(out.size());
}

}  // namespace sd::anatomy
