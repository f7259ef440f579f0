// Anatomy: the object and its per-frame pipeline (anatomy.h): collision set, folding, bulge,
// protrusion, the volume feedback to the deformer and the restoration's calls. Joint set-up is
// in anatomy_joints.cpp, the volume restoration in volume_restoration.cpp.
#include "anatomy/anatomy.h"
#include "anatomy/anatomy_internal.h"
#include "math/flush_denormals.h"

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
double ms_since(Clock::time_point t) { return std::chrono::duration<double, std::milli>(Clock::now() - t).count(); }

}  // namespace

Anatomy::Anatomy(const Rig& rig, const Binding& binding, const int32_t* triangles, int triangle_count) : rig_(rig) {
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
    // The folding's query every frame culls by the normal cone alone: the outline's test
    // doubled the effects' frame (anatomy_bench, 80K body: the first full query 0.74 -> 2.9 ms),
    // and the exact query found no pair left by folding in 1,500 frames of the dance clip
    // (docs/quality.md, nineteenth session). count_intersections and measure are exact.
    backend_ = make_cpu_collision_backend(CpuCollisionOptions{true, 8, true, false});
    checker_ = make_cpu_collision_backend(CpuCollisionOptions{false, 8, true});
    edits_.reset(V);
    falloff_.reset(V);
    triangle_stamp_.assign(mesh_.triangle_count(), 0);
    triangle_joint_.assign(mesh_.triangle_count(), -1);
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
            const dvec3 c =
                (point(rest_.data(), tv[0]) + point(rest_.data(), tv[1]) + point(rest_.data(), tv[2])) / 3.0;
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
    // Triangles the rest mesh already has intersecting (a low-poly body's overlapping faces, a
    // belt through the waist) are the model's, not contact a pose made: folding them moved
    // CesiumMan's knees 5 cm at rest. Folding leaves pairs of two such triangles alone, so the
    // rest pose is reproduced. Pairs of them, not the rest pairs alone: the deformer's rest
    // output differs from the stored mesh by rounding, which flips nearly touching pairs there.
    rest_intersecting_.assign(mesh_.triangle_count(), 0);
    if (!collision_set_.empty()) {
        std::vector<TrianglePair> at_rest;
        checker_->find_pairs(rest_.data(), at_rest);
        for (const TrianglePair& q : at_rest) rest_intersecting_[q.a] = rest_intersecting_[q.b] = 1;
    }
    collision_dirty_ = false;
}

void Anatomy::apply(const SkeletonPose& pose, float* p, Deformer* deformer) {
    if (deformer && (deformer->vertex_count() != vertex_count() || deformer->rig().sweeps.size() != rig_.sweeps.size()))
        throw InvalidInput("the deformer was made for another rig or mesh");
    stats_ = AnatomyStats{};
    stats_.passes = 1;
    const auto t0 = Clock::now();
    apply_pass(pose, p, InFrame{});
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
            for (int k = 0; k < 3; ++k)
                before[k] = edits_.moved(tv[k]) ? edits_.before(tv[k]) : p + 3 * static_cast<size_t>(tv[k]);
            const double dv = signed_volume(p + 3 * static_cast<size_t>(tv[0]), p + 3 * static_cast<size_t>(tv[1]),
                                            p + 3 * static_cast<size_t>(tv[2]), o) -
                              signed_volume(before[0], before[1], before[2], o);
            const int32_t s0 = parts_.sweep[tv[0]], s1 = parts_.sweep[tv[1]], s2 = parts_.sweep[tv[2]];
            const int32_t sw = (s1 == s2) ? s1 : s0;
            if (sw >= 0) change[sw] += dv;
        }
    }
}

void Anatomy::offsets_toward(const std::vector<double>& ic) {
    // Approached with a gain below 1 from the offsets last applied, and bounded.
    for (size_t s = 0; s < offsets_.size(); ++s) {
        const double cap = kMaxOffset * rig_.sweeps[s].rest_volume;
        offsets_[s] = std::clamp(applied_[s] + kFeedbackGain * (ic[s] - applied_[s]), -cap, cap);
    }
}

void Anatomy::correct_in_frame(const InFrame& in_frame, const std::vector<double>& ic, float* p) {
    // As the next frame would take it, from nothing (the frame started with no offsets).
    offsets_toward(ic);
    feed(*in_frame.deformer);
    const size_t n = 3 * static_cast<size_t>(vertex_count());
    corrected_.resize(n);
    const auto t = Clock::now();
    in_frame.deformer->deform(in_frame.pose, corrected_.data());
    for (size_t i = 0; i < n; ++i) p[i] += corrected_[i] - swept_[i];
    stats_.ms_sweeps += ms_since(t);
}

void Anatomy::apply_pass(const SkeletonPose& pose, float* p, const InFrame& in_frame) {
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
        stats_.max_bulge = std::max(
            stats_.max_bulge, m.apply(rig_, pose, jp[m.spec().joint].flexion, J.settings.bulge_strength, p, edits_));
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
        stats_.falloff_vertices +=
            falloff_.apply(mesh_, sources, deltas, protrusion_falloff(j), nullptr, nullptr, p, edits_, j);
    }
    stats_.ms_protrusion += ms_since(t);

    // The volume bulge and protrusion added (before anything else moves).
    t = Clock::now();
    effects_change(jp, early_change_);
    // With the restoration, I_C is what bulge and protrusion added: put back now, so that the
    // restoration's trim and folding below see the skin as it ends.
    if (in_frame.deformer && restore_) correct_in_frame(in_frame, early_change_, p);
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
        drop_rest_pairs(pairs_);
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
            drop_rest_pairs(pairs_);
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
        // In one pass a first-order trim is all the frame gets: a second one, on the skin the
        // first left, takes the place of the second pass's (at 150 degrees the first overshot).
        if (in_frame.deformer) stats_.restored_volume += restore_trim(pose, p);
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
    // only deepens the contact and buries the bone points.
    offsets_toward(restore_ ? early_change_ : total_change_);
    for (double dv : offsets_) stats_.volume_change += dv;
    stats_.ms_volume += ms_since(t);
}

void Anatomy::deform(Deformer& d, const float* pose, float* out) {
    // The passes set the deformer's volume offsets and deform: kept together, and this
    // anatomy's own per-frame state with them, against another thread using the same deformer.
    const auto guard = d.lock();
    const FlushDenormals flush;  // the effects' own passes, on this thread (flush_denormals.h)
    if (d.vertex_count() != vertex_count() || d.rig().sweeps.size() != rig_.sweeps.size() ||
        d.rig().skeleton.bone_count() != rig_.skeleton.bone_count())
        throw InvalidInput("the deformer was made for another rig or mesh");
    stats_ = AnatomyStats{};
    const auto t0 = Clock::now();
    pose_.set(rig_.skeleton, pose);
    if (feedback_ != VolumeFeedback::NextFrame) {
        applied_.assign(rig_.sweeps.size(), 0.0);
        d.set_volume_offsets(applied_);
    }
    // In the frame: the restoration from nothing and I_C put back by the sweeps alone, so the
    // frame depends on its pose only. (A second pass of sweeps and effects did the same and
    // took as long again: collision, folding and restoration are most of a frame.)
    const bool in_frame = feedback_ == VolumeFeedback::InFrame;
    if (in_frame)
        for (RestoreZone& z : restore_zones_) z.height = 0.0;
    auto t = Clock::now();
    d.deform(pose, out);
    stats_.ms_sweeps += ms_since(t);
    if (in_frame) swept_.assign(out, out + 3 * static_cast<size_t>(vertex_count()));
    const InFrame correction = in_frame ? InFrame{&d, pose} : InFrame{};
    apply_pass(pose_, out, correction);
    // Without the restoration I_C includes folding's share: known at the end of the pass.
    if (in_frame && !restore_) correct_in_frame(correction, total_change_, out);
    if (feedback_ != VolumeFeedback::Off) feed(d);
    stats_.passes = 1;
    stats_.ms_total = ms_since(t0);
}

void Anatomy::drop_rest_pairs(std::vector<TrianglePair>& pairs) const {
    pairs.erase(
        std::remove_if(pairs.begin(), pairs.end(),
                       [&](const TrianglePair& q) { return rest_intersecting_[q.a] && rest_intersecting_[q.b]; }),
        pairs.end());
}

int Anatomy::count_intersections(const float* positions, std::vector<TrianglePair>* pairs) {
    if (collision_dirty_) rebuild_collision_set();
    std::vector<TrianglePair> local;
    std::vector<TrianglePair>& out = pairs ? *pairs : local;
    checker_->find_pairs(positions, out);
    return static_cast<int>(out.size());
}

}  // namespace sd::anatomy
