#include "fit/spine_skin.h"

#include "math/segment_distance.h"
#include "math/smoothstep.h"

#include <algorithm>
#include <utility>

namespace sd::fit {

int give_spine_skin_to_bones(const FitMesh& mesh, const Rig& rig, const ChainSet& chains,
                             const std::vector<int>& chain_sweep, int slots, const int32_t* bones, const float* weights,
                             RegionWeights& regions) {
    const int V = mesh.vertex_count();
    const Skeleton& s = rig.skeleton;
    struct Trunk {
        int sweep;
        std::vector<int> links;
        std::vector<std::pair<dvec3, dvec3>> segments;  // link by link, joint to joint
        double inner, outer;
    };
    std::vector<Trunk> trunks;
    for (size_t c = 0; c < chains.chains.size() && c < chain_sweep.size(); ++c) {
        const int si = chain_sweep[c];
        if (si < 0 || !rig.sweeps[si].bends_smoothly) continue;
        const Chain& ch = chains.chains[c];
        Trunk t{si, ch.links(), {}, 0.0, 0.0};
        std::vector<double> depth;
        for (const KeyEllipse& k : rig.sweeps[si].keys)
            if (!k.is_joint_key()) depth.push_back(std::min(k.a, k.b));
        if (depth.empty() || t.links.empty()) continue;
        const std::vector<dvec3> joints = ch.joints(s);  // joint to joint (Chain::joints)
        for (size_t i = 0; i < t.links.size(); ++i) t.segments.push_back({joints[i], joints[i + 1]});
        std::nth_element(depth.begin(), depth.begin() + depth.size() / 2, depth.end());
        t.inner = kSpineSkinInner * depth[depth.size() / 2];
        t.outer = kSpineSkinOuter * depth[depth.size() / 2];
        trunks.push_back(std::move(t));
    }
    if (trunks.empty()) return 0;

    const int SS = regions.sweep_slots, BS = regions.bone_slots;
    std::vector<std::vector<std::pair<float, int>>> rows(V);  // new bone rows
    int changed = 0;
    const std::vector<dvec3>& p = mesh.positions();
    for (int v = 0; v < V; ++v) {
        std::vector<std::pair<float, int>>& row = rows[v];
        for (int i = 0; i < BS; ++i) {
            const int b = regions.bone_ids[static_cast<size_t>(v) * BS + i];
            if (b >= 0) row.push_back({regions.bone_weights[static_cast<size_t>(v) * BS + i], b});
        }
        for (const Trunk& t : trunks)
            for (int i = 0; i < SS; ++i) {
                float& w = regions.sweep_weights[static_cast<size_t>(v) * SS + i];
                if (regions.sweep_ids[static_cast<size_t>(v) * SS + i] != t.sweep || !(w > 0.0f)) continue;
                double d = 1e300;
                for (const auto& [from, to] : t.segments) d = std::min(d, segment_distance(p[v], from, to));
                const double m = 1.0 - smoothstep01((d - t.inner) / (t.outer - t.inner));
                if (!(m > 0.0)) continue;
                double own = 0.0;  // the skin's weight on the chain's links
                for (int j = 0; j < slots; ++j) {
                    const int b = bones[static_cast<size_t>(v) * slots + j];
                    if (b >= 0 && std::find(t.links.begin(), t.links.end(), b) != t.links.end())
                        own += weights[static_cast<size_t>(v) * slots + j];
                }
                if (!(own > 0.0)) continue;
                const float moved = static_cast<float>(m) * w;
                w -= moved;
                for (int j = 0; j < slots; ++j) {
                    const int b = bones[static_cast<size_t>(v) * slots + j];
                    if (b < 0 || std::find(t.links.begin(), t.links.end(), b) == t.links.end()) continue;
                    const float share = static_cast<float>(moved * weights[static_cast<size_t>(v) * slots + j] / own);
                    auto it = std::find_if(row.begin(), row.end(), [&](const auto& e) { return e.second == b; });
                    if (it != row.end())
                        it->first += share;
                    else
                        row.push_back({share, b});
                }
                ++changed;
            }
    }
    if (changed == 0) return 0;
    size_t widest = static_cast<size_t>(BS);
    for (const auto& row : rows) widest = std::max(widest, row.size());
    const int nb = static_cast<int>(widest);
    regions.bone_slots = nb;
    regions.bone_ids.assign(static_cast<size_t>(V) * nb, -1);
    regions.bone_weights.assign(static_cast<size_t>(V) * nb, 0.0f);
    for (int v = 0; v < V; ++v) {
        std::sort(rows[v].begin(), rows[v].end(), [](const auto& a, const auto& b) { return a.first > b.first; });
        for (size_t i = 0; i < rows[v].size(); ++i) {
            regions.bone_ids[static_cast<size_t>(v) * nb + i] = rows[v][i].second;
            regions.bone_weights[static_cast<size_t>(v) * nb + i] = rows[v][i].first;
        }
    }
    return changed;
}

}  // namespace sd::fit
