#include "fit/regions.h"

#include "bind/bind.h"
#include "math/segment_distance.h"
#include "math/smoothstep.h"
#include "rig/skeleton.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>

namespace sd::fit {

namespace {

/// Nearest bone segment of every vertex (optionally only among bones with allowed[b]).
std::vector<int> nearest_bones(const FitMesh& mesh, const Skeleton& s, const std::vector<char>* allowed = nullptr) {
    const int V = mesh.vertex_count(), B = s.bone_count();
    std::vector<int> out(V, -1);
    tbb::parallel_for(0, V, [&](int v) {
        double best = std::numeric_limits<double>::infinity();
        for (int b = 0; b < B; ++b) {
            if (allowed && !(*allowed)[b]) continue;
            const double d = segment_distance(mesh.positions()[v], s.heads[b], s.tails[b]);
            if (d < best) {
                best = d;
                out[v] = b;
            }
        }
    });
    return out;
}

/// Writes one vertex's sweep weights: entries below 1 % of the sweep part dropped, the
/// `slots` largest kept, their sum restored to `total`.
void write_sweeps(std::vector<std::pair<float, int>>& entries, float total, int slots, int32_t* ids, float* w) {
    std::sort(entries.begin(), entries.end(), [](auto& a, auto& b) { return a.first > b.first; });
    float sum = 0.0f;
    int n = 0;
    for (const auto& [weight, id] : entries) {
        if (n == slots || weight < 0.01f * total) break;
        sum += weight;
        ++n;
    }
    for (int i = 0; i < slots; ++i) {
        ids[i] = i < n ? entries[i].second : -1;
        w[i] = i < n && sum > 0.0f ? entries[i].first * total / sum : 0.0f;
    }
}

/// Per vertex the chain whose sweep it lies most inside of (measured in the sweep's own
/// ellipse radii), or -1 where its nearest bone is a rigid part. Nearest bones alone
/// misjudge where limbs lie close to the body (the chest beside a hanging arm is nearer the
/// arm bone than the spine).
std::vector<int> sweep_labels(const FitMesh& mesh, const Rig& rig, const BoneOwners& owners,
                              const std::vector<int>& chain_sweep, const std::vector<int>& nearest) {
    const int V = mesh.vertex_count(), C = static_cast<int>(chain_sweep.size());
    const auto chain_of = [&](int b) {
        return owners.chain[b] >= 0 && chain_sweep[owners.chain[b]] >= 0 ? owners.chain[b] : -1;
    };
    std::vector<std::vector<PlaneSample>> planes;
    for (const Sweep& sweep : rig.sweeps) planes.push_back(sample_planes(sweep));
    std::vector<int> label(V, -1);
    tbb::parallel_for(0, V, [&](int v) {
        if (chain_of(nearest[v]) < 0) return;
        const dvec3 p = mesh.positions()[v];
        double best = std::numeric_limits<double>::infinity();
        for (int c = 0; c < C; ++c) {
            const int si = chain_sweep[c];
            if (si < 0) continue;
            const Sweep& sweep = rig.sweeps[si];
            const SweepInfluence inf = bind_to_sweep(sweep, si, planes[si], p);
            const dvec2 ab = sweep.rest_half_axes.at(inf.span, inf.u);
            double rho2 = (inf.local[0] / ab.x) * (inf.local[0] / ab.x) + (inf.local[1] / ab.y) * (inf.local[1] / ab.y);
            // Beyond an end of the sweep the out-of-plane offset counts as distance too.
            const bool before = inf.span == 0 && inf.u <= 0.0f && inf.local[2] < 0.0f;
            const bool after = inf.span == sweep.span_count() - 1 && inf.u >= 1.0f && inf.local[2] > 0.0f;
            if (before || after) {
                const double z = inf.local[2] / std::min(ab.x, ab.y);
                rho2 += z * z;
            }
            if (rho2 < best) {
                best = rho2;
                label[v] = c;
            }
        }
    });
    return label;
}

}  // namespace

void count_region(RegionWeights& r, int V) {
    r.vertices_bound = r.vertices_on_sweeps = r.vertices_rigid_only = r.vertices_blended = 0;
    for (int v = 0; v < V; ++v) {
        double total = 0.0;
        int sweeps = 0;
        for (int i = 0; i < r.sweep_slots; ++i)
            if (r.sweep_ids[static_cast<size_t>(v) * r.sweep_slots + i] >= 0 &&
                r.sweep_weights[static_cast<size_t>(v) * r.sweep_slots + i] > 0.0f) {
                total += r.sweep_weights[static_cast<size_t>(v) * r.sweep_slots + i];
                ++sweeps;
            }
        for (int i = 0; i < r.bone_slots; ++i)
            if (r.bone_ids[static_cast<size_t>(v) * r.bone_slots + i] >= 0)
                total += r.bone_weights[static_cast<size_t>(v) * r.bone_slots + i];
        r.vertices_bound += total > 0.0 ? 1 : 0;
        r.vertices_on_sweeps += sweeps > 0 ? 1 : 0;
        r.vertices_rigid_only += sweeps == 0 && total > 0.0 ? 1 : 0;
        r.vertices_blended += sweeps >= 2 ? 1 : 0;
    }
}

PartShares shares_from_skin(int V, int slots, const int32_t* bones, const float* weights, const BoneOwners& owners,
                            int C) {
    PartShares p;
    p.chains = C;
    p.share.assign(static_cast<size_t>(V) * C, 0.0f);
    const int B = static_cast<int>(owners.chain.size());
    for (int v = 0; v < V; ++v) {
        double total = 0.0;
        for (int i = 0; i < slots; ++i)
            if (bones[static_cast<size_t>(v) * slots + i] >= 0 && bones[static_cast<size_t>(v) * slots + i] < B)
                total += weights[static_cast<size_t>(v) * slots + i];
        if (!(total > 0.0)) continue;
        for (int i = 0; i < slots; ++i) {
            const int b = bones[static_cast<size_t>(v) * slots + i];
            if (b < 0 || b >= B) continue;
            const int c = owners.chain[b] >= 0 ? owners.chain[b] : owners.attached[b];
            if (c >= 0)
                p.share[static_cast<size_t>(v) * C + c] +=
                    static_cast<float>(weights[static_cast<size_t>(v) * slots + i] / total);
        }
    }
    return p;
}

PartShares shares_from_nearest_bones(const FitMesh& mesh, const Skeleton& s, const BoneOwners& owners, int C) {
    PartShares p;
    p.chains = C;
    const int V = mesh.vertex_count();
    p.share.assign(static_cast<size_t>(V) * C, 0.0f);
    const std::vector<int> nearest = nearest_bones(mesh, s);
    for (int v = 0; v < V; ++v) {
        const int b = nearest[v];
        const int c = owners.chain[b] >= 0 ? owners.chain[b] : owners.attached[b];
        if (c >= 0) p.share[static_cast<size_t>(v) * C + c] = 1.0f;
    }
    smooth_rows(mesh, C, p.share, std::vector<char>(V, 1), 3, 0.5f);
    return p;
}

PartShares shares_from_sweeps(const FitMesh& mesh, const Rig& rig, const BoneOwners& owners,
                              const std::vector<int>& chain_sweep) {
    const int V = mesh.vertex_count(), C = static_cast<int>(chain_sweep.size());
    PartShares p;
    p.chains = C;
    p.share.assign(static_cast<size_t>(V) * C, 0.0f);
    const std::vector<int> nearest = nearest_bones(mesh, rig.skeleton);
    const std::vector<int> label = sweep_labels(mesh, rig, owners, chain_sweep, nearest);
    for (int v = 0; v < V; ++v) {
        const int b = nearest[v];
        const int c = label[v] >= 0 ? label[v] : (owners.chain[b] >= 0 ? owners.chain[b] : owners.attached[b]);
        if (c >= 0) p.share[static_cast<size_t>(v) * C + c] = 1.0f;
    }
    smooth_rows(mesh, C, p.share, std::vector<char>(V, 1), 3, 0.5f);
    return p;
}

void smooth_rows(const FitMesh& mesh, int width, std::vector<float>& values, const std::vector<char>& active,
                 int iterations, float lambda, double reach) {
    const int V = mesh.vertex_count();
    const auto& off = mesh.ring_offsets();
    const auto& ring = mesh.ring();
    const auto& pos = mesh.positions();
    std::vector<float> step(V, lambda);
    if (reach > 0.0)
        tbb::parallel_for(0, V, [&](int v) {
            double sum = 0.0;
            int n = 0;
            for (int i = off[v]; i < off[v + 1]; ++i, ++n) sum += glm::length(pos[ring[i]] - pos[v]);
            const double edge = n > 0 ? sum / n : 0.0;
            if (edge > reach) step[v] = static_cast<float>(lambda * (reach / edge) * (reach / edge));
        });
    std::vector<float> next = values;
    for (int it = 0; it < iterations; ++it) {
        tbb::parallel_for(0, V, [&](int v) {
            if (!active[v]) return;
            float* out = &next[static_cast<size_t>(v) * width];
            const float* own = &values[static_cast<size_t>(v) * width];
            int n = 0;
            for (int i = off[v]; i < off[v + 1]; ++i) n += active[ring[i]] ? 1 : 0;
            if (n == 0) return;
            const float l = step[v];
            for (int c = 0; c < width; ++c) {
                float sum = 0.0f;
                for (int i = off[v]; i < off[v + 1]; ++i)
                    if (active[ring[i]]) sum += values[static_cast<size_t>(ring[i]) * width + c];
                out[c] = (1.0f - l) * own[c] + l * sum / static_cast<float>(n);
            }
        });
        values.swap(next);
    }
}

RegionWeights weights_from_skin(const FitMesh& mesh, const Skeleton& s, const BoneOwners& owners,
                                const std::vector<int>& chain_sweep, int slots, const int32_t* bones,
                                const float* weights, const RegionOptions& opt) {
    const int V = mesh.vertex_count(), C = static_cast<int>(chain_sweep.size()), B = s.bone_count();
    RegionWeights r;
    r.source = "skin weights";
    r.sweep_slots = opt.sweep_slots;
    r.bone_slots = std::max(1, slots);
    r.sweep_ids.assign(static_cast<size_t>(V) * r.sweep_slots, -1);
    r.sweep_weights.assign(r.sweep_ids.size(), 0.0f);
    r.bone_ids.assign(static_cast<size_t>(V) * r.bone_slots, -1);
    r.bone_weights.assign(r.bone_ids.size(), 0.0f);

    // Unweighted vertices (loose parts the artist forgot) take their nearest bone.
    std::vector<char> unweighted(V, 0);
    for (int v = 0; v < V; ++v) {
        double total = 0.0;
        for (int i = 0; i < slots; ++i)
            if (bones[static_cast<size_t>(v) * slots + i] >= 0) total += weights[static_cast<size_t>(v) * slots + i];
        unweighted[v] = !(total > 0.0);
        r.vertices_from_nearest_bone += unweighted[v];
    }
    std::vector<int> nearest;
    if (r.vertices_from_nearest_bone > 0) nearest = nearest_bones(mesh, s);

    // The sweep a bone's skin weight goes to. An inner link (clavicle, hip bone) has none: the
    // sweep starts at the joint after it, and skin on it (chest, back, the base of the neck)
    // bound to the sweep would lie before the sweep's first plane and turn rigidly with its
    // first key about the shoulder, half the arm's swing, while the skin beside it stays with
    // the torso: a fold across the chest when the arms go up. The bone itself drives it, as
    // the skinning does, and the transition to the arm's sweep is the skin's own.
    const auto chain_of = [&](int b) {
        if (b < 0 || b >= B || owners.chain[b] < 0 || chain_sweep[owners.chain[b]] < 0) return -1;
        if (!owners.inner.empty() && owners.inner[b]) return -1;
        return owners.chain[b];
    };
    std::vector<float> split(static_cast<size_t>(V) * C, 0.0f), sweep_total(V, 0.0f);
    std::vector<char> active(V, 0);
    for (int v = 0; v < V; ++v) {
        float* row = &split[static_cast<size_t>(v) * C];
        double total = 0.0;
        const auto add = [&](int b, double w) {
            total += w;
            const int c = chain_of(b);
            if (c >= 0) row[c] += static_cast<float>(w);
        };
        if (unweighted[v]) {
            add(nearest[v], 1.0);
        } else {
            for (int i = 0; i < slots; ++i)
                if (bones[static_cast<size_t>(v) * slots + i] >= 0)
                    add(bones[static_cast<size_t>(v) * slots + i], weights[static_cast<size_t>(v) * slots + i]);
        }
        float chains_sum = 0.0f;
        for (int c = 0; c < C; ++c) chains_sum += row[c];
        sweep_total[v] = static_cast<float>(chains_sum / total);
        active[v] = chains_sum > 0.0f;
        for (int c = 0; c < C && chains_sum > 0.0f; ++c) row[c] /= chains_sum;
    }
    smooth_rows(mesh, C, split, active, opt.smoothing_iterations, opt.smoothing_step,
                kSmoothingReachOfDiagonal * mesh.diagonal());

    tbb::parallel_for(0, V, [&](int v) {
        std::vector<std::pair<float, int>> entries;
        if (active[v])
            for (int c = 0; c < C; ++c)
                if (split[static_cast<size_t>(v) * C + c] > 0.0f)
                    entries.push_back({split[static_cast<size_t>(v) * C + c], chain_sweep[c]});
        write_sweeps(entries, sweep_total[v], r.sweep_slots, &r.sweep_ids[static_cast<size_t>(v) * r.sweep_slots],
                     &r.sweep_weights[static_cast<size_t>(v) * r.sweep_slots]);
        // Rigid parts keep the skin's own weights, relative to the vertex's total.
        std::vector<std::pair<float, int>> rigid;
        if (unweighted[v]) {
            if (chain_of(nearest[v]) < 0) rigid.push_back({1.0f, nearest[v]});
        } else {
            double total = 0.0;
            for (int i = 0; i < slots; ++i)
                if (bones[static_cast<size_t>(v) * slots + i] >= 0)
                    total += weights[static_cast<size_t>(v) * slots + i];
            for (int i = 0; i < slots; ++i) {
                const int b = bones[static_cast<size_t>(v) * slots + i];
                if (b >= 0 && chain_of(b) < 0 && weights[static_cast<size_t>(v) * slots + i] > 0.0f)
                    rigid.push_back({static_cast<float>(weights[static_cast<size_t>(v) * slots + i] / total), b});
            }
        }
        std::sort(rigid.begin(), rigid.end(), [](auto& a, auto& b) { return a.first > b.first; });
        for (int i = 0; i < r.bone_slots && i < static_cast<int>(rigid.size()); ++i) {
            r.bone_ids[static_cast<size_t>(v) * r.bone_slots + i] = rigid[i].second;
            r.bone_weights[static_cast<size_t>(v) * r.bone_slots + i] = rigid[i].first;
        }
    });
    count_region(r, V);
    return r;
}

RegionWeights weights_from_geometry(const FitMesh& mesh, const Rig& rig, const ChainSet& set, const BoneOwners& owners,
                                    const std::vector<int>& chain_sweep, const RegionOptions& opt) {
    const Skeleton& s = rig.skeleton;
    const int V = mesh.vertex_count(), C = static_cast<int>(chain_sweep.size()), B = s.bone_count();
    const int W = C + 1;  // one column per chain, the last for rigid parts
    RegionWeights r;
    r.source = "geometry";
    r.sweep_slots = opt.sweep_slots;
    r.bone_slots = 1;
    r.sweep_ids.assign(static_cast<size_t>(V) * r.sweep_slots, -1);
    r.sweep_weights.assign(r.sweep_ids.size(), 0.0f);
    r.bone_ids.assign(static_cast<size_t>(V), -1);
    r.bone_weights.assign(static_cast<size_t>(V), 0.0f);

    const std::vector<int> nearest = nearest_bones(mesh, s);
    const auto chain_of = [&](int b) {
        return owners.chain[b] >= 0 && chain_sweep[owners.chain[b]] >= 0 ? owners.chain[b] : -1;
    };
    std::vector<char> rigid_bone(B, 0);
    for (int b = 0; b < B; ++b) rigid_bone[b] = chain_of(b) < 0;
    const std::vector<int> label = sweep_labels(mesh, rig, owners, chain_sweep, nearest);
    std::vector<float> part(static_cast<size_t>(V) * W, 0.0f);
    std::vector<int> rigid_of(V, -1);  // the rigid bone a vertex's rigid weight goes to
    for (int v = 0; v < V; ++v) {
        const int c = label[v];
        if (c >= 0) {
            part[static_cast<size_t>(v) * W + c] = 1.0f;
        } else {
            part[static_cast<size_t>(v) * W + C] = 1.0f;
            rigid_of[v] = nearest[v];
        }
    }
    // Transitions by two bounding planes parallel to a key ellipse, at ±δ from it.
    const auto blend = [&](const KeyEllipse& key, int inner, int outer, int outer_bone) {
        const dvec3 n = key.normal();
        const double radius = std::max(key.a, key.b), delta = 0.5 * radius;
        for (int v = 0; v < V; ++v) {
            const dvec3 d = mesh.positions()[v] - key.center;
            const double along = glm::dot(d, n);
            if (std::abs(along) >= delta || glm::length(d - along * n) > 1.5 * radius) continue;
            float* row = &part[static_cast<size_t>(v) * W];
            if (row[inner] + row[outer] < 0.5f) continue;  // another part passing by
            const float w = static_cast<float>(smoothstep01((along + delta) / (2.0 * delta)));
            row[inner] = 1.0f - w;
            row[outer] = w;
            if (outer == C) rigid_of[v] = outer_bone;
        }
    };
    for (int c = 0; c < C; ++c) {
        if (chain_sweep[c] < 0) continue;
        const Sweep& sweep = rig.sweeps[chain_sweep[c]];
        const Chain& ch = set.chains[c];
        if (ch.parent_chain >= 0 && chain_sweep[ch.parent_chain] >= 0)
            blend(sweep.keys.front(), ch.parent_chain, c, -1);
        if (ch.end_bone >= 0 && rigid_bone[ch.end_bone]) blend(sweep.keys.back(), c, C, ch.end_bone);
    }
    smooth_rows(mesh, W, part, std::vector<char>(V, 1), opt.smoothing_iterations, opt.smoothing_step,
                kSmoothingReachOfDiagonal * mesh.diagonal());

    // Vertices that smoothing gave some rigid weight without a rigid bone of their own take
    // the nearest rigid bone.
    std::vector<int> nearest_rigid;
    bool need = false;
    for (int v = 0; v < V && !need; ++v) need = rigid_of[v] < 0 && part[static_cast<size_t>(v) * W + C] > 0.0f;
    if (need && std::find(rigid_bone.begin(), rigid_bone.end(), 1) != rigid_bone.end())
        nearest_rigid = nearest_bones(mesh, s, &rigid_bone);
    tbb::parallel_for(0, V, [&](int v) {
        const float* row = &part[static_cast<size_t>(v) * W];
        int rigid = rigid_of[v] >= 0 ? rigid_of[v] : (nearest_rigid.empty() ? -1 : nearest_rigid[v]);
        float sum = 0.0f;
        for (int c = 0; c < W; ++c) sum += (c < C || rigid >= 0) ? std::max(row[c], 0.0f) : 0.0f;
        if (!(sum > 0.0f)) {  // cannot happen for a connected labelling; stay bound anyway
            rigid = nearest[v];
            sum = 1.0f;
        }
        std::vector<std::pair<float, int>> entries;
        for (int c = 0; c < C; ++c)
            if (row[c] > 0.0f) entries.push_back({row[c] / sum, chain_sweep[c]});
        float sweep_sum = 0.0f;
        for (const auto& e : entries) sweep_sum += e.first;
        float rigid_w = rigid >= 0 ? std::max(row[C], 0.0f) / sum : 0.0f;
        if (entries.empty() && !(rigid_w > 0.0f)) rigid_w = 1.0f;
        write_sweeps(entries, sweep_sum, r.sweep_slots, &r.sweep_ids[static_cast<size_t>(v) * r.sweep_slots],
                     &r.sweep_weights[static_cast<size_t>(v) * r.sweep_slots]);
        if (rigid >= 0 && rigid_w > 0.0f) {
            r.bone_ids[v] = rigid;
            r.bone_weights[v] = rigid_w;
        }
    });
    r.vertices_from_nearest_bone = V;
    count_region(r, V);
    return r;
}

}  // namespace sd::fit
