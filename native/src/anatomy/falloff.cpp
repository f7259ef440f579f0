#include "anatomy/falloff.h"

#include <algorithm>
#include <limits>
#include <queue>

namespace sd::anatomy {

void VertexEdits::reset(int V) {
    flag_.assign(V, 0);
    owner_.assign(V, -1);
    before_.assign(3 * static_cast<size_t>(V), 0.0f);
    list_.clear();
}

void VertexEdits::clear() {
    for (int32_t v : list_) flag_[v] = 0;
    list_.clear();
}

void Falloff::reset(int V) {
    dist_.assign(V, std::numeric_limits<float>::infinity());
    nearest_.assign(V, -1);
    touched_.clear();
}

int Falloff::apply(const MeshTopology& mesh, const std::vector<int32_t>& sources, const std::vector<dvec3>& deltas,
                   double radius, const int32_t* labels, const uint8_t* label_allowed, float* p, VertexEdits& edits,
                   int owner, std::vector<int32_t>* moved) {
    if (static_cast<int>(dist_.size()) != mesh.vertex_count) reset(mesh.vertex_count);
    // Multi-source Dijkstra bounded by the radius.
    using Item = std::pair<float, int32_t>;
    std::priority_queue<Item, std::vector<Item>, std::greater<Item>> heap;
    for (size_t i = 0; i < sources.size(); ++i) {
        const int32_t s = sources[i];
        if (dist_[s] == 0.0f) continue;  // listed twice: the first delta wins
        if (dist_[s] == std::numeric_limits<float>::infinity()) touched_.push_back(s);
        dist_[s] = 0.0f;
        nearest_[s] = static_cast<int32_t>(i);
        heap.push({0.0f, s});
    }
    const float r = static_cast<float>(radius);
    if (r > 0.0f) {
        while (!heap.empty()) {
            const auto [d, v] = heap.top();
            heap.pop();
            if (d > dist_[v]) continue;
            for (uint32_t e = mesh.neighbour_offsets[v]; e < mesh.neighbour_offsets[v + 1]; ++e) {
                const int32_t n = mesh.neighbours[e];
                if (labels && (labels[n] < 0 || !label_allowed[labels[n]])) continue;
                const float nd = d + mesh.edge_lengths[e];
                if (nd >= r || nd >= dist_[n]) continue;
                if (dist_[n] == std::numeric_limits<float>::infinity()) touched_.push_back(n);
                dist_[n] = nd;
                nearest_[n] = nearest_[v];
                heap.push({nd, n});
            }
        }
    }
    int falloff = 0;
    for (int32_t v : touched_) {
        const float d = dist_[v];
        const dvec3& delta = deltas[nearest_[v]];
        double w = 1.0;
        if (d > 0.0f) {
            const double s = d / r;
            w = (1.0 - s * s) * (1.0 - s * s);
            ++falloff;
        }
        edits.touch(v, p, owner);
        if (moved) moved->push_back(v);
        for (int k = 0; k < 3; ++k) p[3 * static_cast<size_t>(v) + k] += static_cast<float>(w * delta[k]);
        dist_[v] = std::numeric_limits<float>::infinity();
        nearest_[v] = -1;
    }
    touched_.clear();
    return falloff;
}

}  // namespace sd::anatomy
