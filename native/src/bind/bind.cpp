#include "bind/bind.h"

#include "bind/serialize.h"
#include "math/smoothstep.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <limits>

namespace sd {

std::vector<PlaneSample> sample_planes(const Sweep& s) {
    std::vector<PlaneSample> planes;
    const SweepGeometry& g = s.rest_geometry;
    for (int span = 0; span < g.span_count(); ++span)
        for (int j = 0; j < kBindSamplesPerSpan; ++j) {
            const double u = static_cast<double>(j) / kBindSamplesPerSpan;
            planes.push_back({span, u, g.center(span, u), g.normal(span, u)});
        }
    const int last = g.span_count() - 1;
    planes.push_back({last, 1.0, g.center(last, 1.0), g.normal(last, 1.0)});
    return planes;
}

namespace {

SweepInfluence local_coordinates(const Sweep& s, int sweep_index, int span, double u, const dvec3& v) {
    const dmat3 r = s.rest_geometry.rotation(span, u);
    const dvec3 local = glm::transpose(r) * (v - s.rest_geometry.center(span, u));
    const dvec2 ab = s.rest_half_axes.at(span, u);
    const double theta = std::atan2(local.y / ab.y, local.x / ab.x);
    SweepInfluence inf;
    inf.sweep = sweep_index;
    inf.span = span;
    inf.u = static_cast<float>(u);
    for (int i = 0; i < 3; ++i) inf.local[i] = static_cast<float>(local[i]);
    inf.cos_theta = static_cast<float>(std::cos(theta));
    inf.sin_theta = static_cast<float>(std::sin(theta));
    return inf;
}

/// Global parameter of a plane sample, for the paper's distance interpolation.
double global_t(const Sweep& s, int span, double u) {
    const auto& k = s.rest_geometry.knots();
    return k[span] + u * (k[span + 1] - k[span]);
}

void t_to_span(const Sweep& s, double t, int* span, double* u) {
    const auto& k = s.rest_geometry.knots();
    int i = 0;
    while (i + 1 < s.span_count() && t > k[i + 1]) ++i;
    *span = i;
    *u = std::clamp((t - k[i]) / (k[i + 1] - k[i]), 0.0, 1.0);
}

}  // namespace

SweepInfluence bind_to_sweep(const Sweep& s, int sweep_index, const std::vector<PlaneSample>& planes, const dvec3& v) {
    // Candidates: every pair of consecutive planes that encloses V, plus the two ends
    // (vertices beyond an end plane stay with the end ellipse). Far from the axis several
    // planes may enclose V; the binding nearest to the axis is the right one.
    double best_distance = std::numeric_limits<double>::infinity();
    int best_span = 0;
    double best_u = 0.0;
    const auto consider = [&](int span, double u) {
        const double d = glm::length(v - s.rest_geometry.center(span, u));
        if (d < best_distance) {
            best_distance = d;
            best_span = span;
            best_u = u;
        }
    };
    const auto side = [&](size_t j) { return glm::dot(v - planes[j].center, planes[j].normal); };
    if (side(0) <= 0.0) consider(0, 0.0);
    if (side(planes.size() - 1) >= 0.0) consider(s.span_count() - 1, 1.0);
    double next = side(0);
    for (size_t j = 0; j + 1 < planes.size(); ++j) {
        const double here = next;
        next = side(j + 1);
        if (!(here >= 0.0 && next < 0.0)) continue;
        const double dj = std::abs(here), dn = std::abs(next);
        const double tj = global_t(s, planes[j].span, planes[j].u);
        const double tn = global_t(s, planes[j + 1].span, planes[j + 1].u);
        const double tv = (dn * tj + dj * tn) / (dj + dn);
        int span;
        double u;
        t_to_span(s, tv, &span, &u);
        consider(span, u);
    }
    return local_coordinates(s, sweep_index, best_span, best_u, v);
}

Binding bind_vertices(const Rig& rig, int V, const float* positions, int S, const int32_t* sweep_ids,
                      const float* sweep_weights, int K, const int32_t* bone_ids, const float* bone_weights,
                      bool weights_handed_over) {
    if (V < 1 || V > 50'000'000) throw InvalidInput("vertex count must be in 1..5e7");
    if (!positions) throw InvalidInput("positions is NULL");
    if (S < 0 || S > 16 || K < 0 || K > 64) throw InvalidInput("sweep slots must be in 0..16 and bone slots in 0..64");
    if (S > 0 && (!sweep_ids || !sweep_weights)) throw InvalidInput("sweep ids/weights are NULL");
    if (K > 0 && (!bone_ids || !bone_weights)) throw InvalidInput("bone ids/weights are NULL");
    const int sweep_count = static_cast<int>(rig.sweeps.size());
    const int bone_count = rig.skeleton.bone_count();

    Binding b;
    b.rest_positions.assign(positions, positions + static_cast<size_t>(V) * 3);
    b.sweep_offsets.assign(V + 1, 0);
    b.bone_offsets.assign(V + 1, 0);
    // First pass (serial, cheap): validate and lay out the rows.
    for (int v = 0; v < V; ++v) {
        const std::string where = "vertex " + std::to_string(v);
        for (int i = 0; i < 3; ++i)
            if (!std::isfinite(positions[3 * v + i]) || std::abs(positions[3 * v + i]) > 1e12)
                throw InvalidInput(where + " has a non-finite or enormous coordinate");
        double total = 0.0;
        for (int i = 0; i < S; ++i) {
            const int id = sweep_ids[v * S + i];
            const float w = sweep_weights[v * S + i];
            if (id == -1) continue;
            if (id < 0 || id >= sweep_count)
                throw InvalidInput(where + ": sweep index " + std::to_string(id) + " out of range");
            if (!(w >= 0.0f) || !std::isfinite(w)) throw InvalidInput(where + ": negative or non-finite weight");
            if (w > 0.0f) {
                b.sweep_influences.push_back(SweepInfluence{id, 0, 0.0f, w, {0, 0, 0}, 1, 0});
                total += w;
            }
        }
        for (int i = 0; i < K; ++i) {
            const int id = bone_ids[v * K + i];
            const float w = bone_weights[v * K + i];
            if (id == -1) continue;
            if (id < 0 || id >= bone_count)
                throw InvalidInput(where + ": bone index " + std::to_string(id) + " out of range");
            if (!(w >= 0.0f) || !std::isfinite(w)) throw InvalidInput(where + ": negative or non-finite weight");
            if (w > 0.0f) {
                b.bone_influences.push_back(BoneInfluence{id, w});
                total += w;
            }
        }
        if (!(total > 0.0)) throw InvalidInput(where + " has no sweep or bone weight");
        b.sweep_offsets[v + 1] = static_cast<uint32_t>(b.sweep_influences.size());
        b.bone_offsets[v + 1] = static_cast<uint32_t>(b.bone_influences.size());
        for (uint32_t i = b.sweep_offsets[v]; i < b.sweep_offsets[v + 1]; ++i)
            b.sweep_influences[i].weight = static_cast<float>(b.sweep_influences[i].weight / total);
        for (uint32_t i = b.bone_offsets[v]; i < b.bone_offsets[v + 1]; ++i)
            b.bone_influences[i].weight = static_cast<float>(b.bone_influences[i].weight / total);
    }
    // Second pass (parallel): the geometric binding of each sweep influence.
    std::vector<std::vector<PlaneSample>> planes;
    for (const Sweep& sweep : rig.sweeps) planes.push_back(sample_planes(sweep));
    tbb::parallel_for(0, V, [&](int v) {
        const dvec3 p(positions[3 * v], positions[3 * v + 1], positions[3 * v + 2]);
        for (uint32_t i = b.sweep_offsets[v]; i < b.sweep_offsets[v + 1]; ++i) {
            SweepInfluence& inf = b.sweep_influences[i];
            const float w = inf.weight;
            inf = bind_to_sweep(rig.sweeps[inf.sweep], inf.sweep, planes[inf.sweep], p);
            inf.weight = w;
        }
    });
    if (!weights_handed_over) hand_over_at_sweep_ends(rig, positions, b);
    b.rig_fingerprint = rig_fingerprint(rig);
    return b;
}

void hand_over_at_sweep_ends(const Rig& rig, const float* positions, Binding& b) {
    // A sweep's end key turns with half its joint's swing, which suits the limb's own cross
    // sections but not skin beyond the end planes: the side of the chest that the skin's
    // weights give partly to the upper arm, bound to the arm's first ellipse, rose only half
    // as far as the arm did (a shelf at the armpit), and the hand's skin weight a few
    // centimetres up the forearm dragged it towards the hand's full twist (a groove). So:
    //  - beyond an end plane the sweep's weight passes to the end key's own bone, over a
    //    distance of kHandOverReach times the ellipse's larger half-axis;
    //  - before it, the weight of the end key's bone (the hand's on the forearm) passes to
    //    the sweep, over the same distance.
    // A shorter hand-over bends the skin sharply where it ends: at 1, 2, 3 and 4 half-axes
    // MakeHuman's shoulder band (arms up 110 degrees, shoulder_test.cpp) creases by 51, 40,
    // 33 and 27 degrees, linear blend skinning by 45.
    //  Both only near the end ellipse: within 1.5 of its radii from its center, fading out by
    //  2.5 (the shoulders beside a torso's last plane, at the base of the neck, are the
    //  torso's, not the neck's).
    struct End {
        int sweep, bone;
        dvec3 center, normal;  // normal pointing out of the sweep
        dmat3 axes;            // the end ellipse's frame
        double a, b, reach;
    };
    std::vector<End> ends;
    for (int si = 0; si < static_cast<int>(rig.sweeps.size()); ++si) {
        const Sweep& s = rig.sweeps[si];
        const SweepGeometry& g = s.rest_geometry;
        const KeyEllipse &first = s.keys.front(), &last = s.keys.back();
        const int end_span = s.span_count() - 1;
        if (first.is_joint_key())
            ends.push_back({si, first.bone, g.center(0, 0.0), -g.normal(0, 0.0), g.rotation(0, 0.0), first.a, first.b,
                            std::max(first.a, first.b)});
        if (last.is_joint_key())
            ends.push_back({si, last.bone, g.center(end_span, 1.0), g.normal(end_span, 1.0), g.rotation(end_span, 1.0),
                            last.a, last.b, std::max(last.a, last.b)});
    }
    if (ends.empty()) return;
    const int V = b.vertex_count();
    std::vector<uint32_t> sweep_offsets(V + 1, 0), bone_offsets(V + 1, 0);
    std::vector<SweepInfluence> sweeps;
    std::vector<BoneInfluence> bones;
    sweeps.reserve(b.sweep_influences.size());
    bones.reserve(b.bone_influences.size());
    for (int v = 0; v < V; ++v) {
        const dvec3 p(positions[3 * v], positions[3 * v + 1], positions[3 * v + 2]);
        std::vector<SweepInfluence> row_s(b.sweep_influences.begin() + b.sweep_offsets[v],
                                          b.sweep_influences.begin() + b.sweep_offsets[v + 1]);
        std::vector<BoneInfluence> row_b(b.bone_influences.begin() + b.bone_offsets[v],
                                         b.bone_influences.begin() + b.bone_offsets[v + 1]);
        for (const End& e : ends) {
            auto own =
                std::find_if(row_s.begin(), row_s.end(), [&](const SweepInfluence& i) { return i.sweep == e.sweep; });
            if (own == row_s.end()) continue;
            const dvec3 d = p - e.center;
            const double radial = std::hypot(glm::dot(d, e.axes[0]) / e.a, glm::dot(d, e.axes[1]) / e.b);
            const double near = 1.0 - smoothstep01(radial - 1.5);
            if (!(near > 0.0)) continue;
            const double beyond = glm::dot(d, e.normal) / std::max(kHandOverReach * e.reach, 1e-12);
            auto bone =
                std::find_if(row_b.begin(), row_b.end(), [&](const BoneInfluence& i) { return i.bone == e.bone; });
            if (beyond > 0.0) {
                const float moved = static_cast<float>(near * smoothstep01(beyond)) * own->weight;
                if (!(moved > 0.0f)) continue;
                own->weight -= moved;
                if (bone != row_b.end())
                    bone->weight += moved;
                else
                    row_b.push_back({e.bone, moved});
            } else if (bone != row_b.end()) {
                const float moved = static_cast<float>(near * smoothstep01(-beyond)) * bone->weight;
                bone->weight -= moved;
                own->weight += moved;
            }
        }
        for (const SweepInfluence& i : row_s)
            if (i.weight > 0.0f) sweeps.push_back(i);
        for (const BoneInfluence& i : row_b)
            if (i.weight > 0.0f) bones.push_back(i);
        sweep_offsets[v + 1] = static_cast<uint32_t>(sweeps.size());
        bone_offsets[v + 1] = static_cast<uint32_t>(bones.size());
    }
    b.sweep_influences = std::move(sweeps);
    b.bone_influences = std::move(bones);
    b.sweep_offsets = std::move(sweep_offsets);
    b.bone_offsets = std::move(bone_offsets);
}

Binding binding_of_vertices(const Binding& binding, const std::vector<int32_t>& vertices) {
    Binding b;
    b.rig_fingerprint = binding.rig_fingerprint;
    b.sweep_offsets.push_back(0);
    b.bone_offsets.push_back(0);
    for (int32_t v : vertices) {
        b.rest_positions.insert(b.rest_positions.end(), binding.rest_positions.begin() + 3 * static_cast<size_t>(v),
                                binding.rest_positions.begin() + 3 * static_cast<size_t>(v) + 3);
        b.sweep_influences.insert(b.sweep_influences.end(), binding.sweep_influences.begin() + binding.sweep_offsets[v],
                                  binding.sweep_influences.begin() + binding.sweep_offsets[v + 1]);
        b.bone_influences.insert(b.bone_influences.end(), binding.bone_influences.begin() + binding.bone_offsets[v],
                                 binding.bone_influences.begin() + binding.bone_offsets[v + 1]);
        b.sweep_offsets.push_back(static_cast<uint32_t>(b.sweep_influences.size()));
        b.bone_offsets.push_back(static_cast<uint32_t>(b.bone_influences.size()));
    }
    return b;
}

void Binding::check_structure() const {
    const size_t V = rest_positions.size() / 3;
    if (rest_positions.size() % 3 != 0 || V < 1) throw CorruptData("binding has no vertices");
    if (sweep_offsets.size() != V + 1 || bone_offsets.size() != V + 1)
        throw CorruptData("binding row offsets have the wrong length");
    for (float x : rest_positions)
        if (!std::isfinite(x)) throw CorruptData("binding has a non-finite rest position");
    const auto rows_ok = [](const std::vector<uint32_t>& o, size_t n) {
        if (o.front() != 0 || o.back() != n) return false;
        for (size_t i = 1; i < o.size(); ++i)
            if (o[i] < o[i - 1]) return false;
        return true;
    };
    if (!rows_ok(sweep_offsets, sweep_influences.size()) || !rows_ok(bone_offsets, bone_influences.size()))
        throw CorruptData("binding rows are not consistent");
    for (const SweepInfluence& s : sweep_influences) {
        bool ok = std::isfinite(s.u) && s.u >= 0.0f && s.u <= 1.0f && std::isfinite(s.weight) &&
                  std::isfinite(s.cos_theta) && std::isfinite(s.sin_theta);
        for (float x : s.local) ok = ok && std::isfinite(x);
        if (!ok) throw CorruptData("binding has a non-finite sweep parameter");
    }
    for (const BoneInfluence& bi : bone_influences)
        if (!std::isfinite(bi.weight)) throw CorruptData("binding has a non-finite bone weight");
}

void Binding::check_against(const Rig& rig) const {
    for (const SweepInfluence& s : sweep_influences)
        if (s.sweep < 0 || s.sweep >= static_cast<int>(rig.sweeps.size()) || s.span < 0 ||
            s.span >= rig.sweeps[s.sweep].span_count())
            throw InvalidInput(
                "the binding refers to a sweep or span the rig does not have; "
                "re-bind");
    for (const BoneInfluence& b : bone_influences)
        if (b.bone < 0 || b.bone >= rig.skeleton.bone_count())
            throw InvalidInput("the binding refers to a bone the rig does not have; re-bind");
}

}  // namespace sd
