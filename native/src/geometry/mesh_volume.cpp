#include "geometry/mesh_volume.h"

#include "math/math_types.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <map>
#include <set>

namespace sd::anatomy {

namespace {

std::vector<std::vector<std::pair<int32_t, int32_t>>> boundary_loops(const MeshTopology& mesh,
                                                                     const std::vector<int32_t>& triangles) {
    std::set<std::pair<int32_t, int32_t>> edges;
    for (int32_t t : triangles) {
        const int32_t* tv = mesh.triangle(t);
        for (int k = 0; k < 3; ++k) edges.insert({tv[k], tv[(k + 1) % 3]});
    }
    // Boundary: directed edges whose reverse is not in the region, chained into loops.
    std::multimap<int32_t, int32_t> next;
    for (const auto& e : edges)
        if (!edges.count({e.second, e.first})) next.insert({e.first, e.second});
    std::vector<std::vector<std::pair<int32_t, int32_t>>> loops;
    while (!next.empty()) {
        std::vector<std::pair<int32_t, int32_t>> loop;
        auto it = next.begin();
        const int32_t start = it->first;
        while (it != next.end()) {
            loop.push_back({it->first, it->second});
            const int32_t at = it->second;
            next.erase(it);
            if (at == start) break;
            it = next.find(at);
        }
        loops.push_back(std::move(loop));
    }
    return loops;
}

}  // namespace

double mesh_volume(const MeshTopology& mesh, const float* p) {
    const double o[3] = {0, 0, 0};
    double v = 0.0;
    for (int t = 0; t < mesh.triangle_count(); ++t) {
        const int32_t* tv = mesh.triangle(t);
        v += signed_volume(p + 3 * static_cast<size_t>(tv[0]), p + 3 * static_cast<size_t>(tv[1]),
                           p + 3 * static_cast<size_t>(tv[2]), o);
    }
    return v;
}

double closed_region_volume(const MeshTopology& mesh, const std::vector<int32_t>& triangles, const float* p) {
    return ClosedRegion(mesh, triangles).volume(p);
}

ClosedRegion::ClosedRegion(const MeshTopology& mesh, std::vector<int32_t> triangles)
    : mesh_(&mesh), triangles_(std::move(triangles)), loops_(boundary_loops(mesh, triangles_)) {}

double ClosedRegion::volume(const float* p) const {
    if (!mesh_ || triangles_.empty()) return 0.0;
    // Reference point: the region's first vertex keeps the sums small.
    const int32_t r0 = mesh_->triangle(triangles_[0])[0];
    const double o[3] = {p[3 * r0], p[3 * r0 + 1], p[3 * r0 + 2]};
    constexpr size_t kBlock = 4096;
    const size_t blocks = (triangles_.size() + kBlock - 1) / kBlock;
    std::vector<double> partial(blocks, 0.0);
    tbb::parallel_for(size_t(0), blocks, [&](size_t b) {
        double sum = 0.0;
        const size_t end = std::min(triangles_.size(), (b + 1) * kBlock);
        for (size_t i = b * kBlock; i < end; ++i) {
            const int32_t* tv = mesh_->triangle(triangles_[i]);
            sum += signed_volume(p + 3 * static_cast<size_t>(tv[0]), p + 3 * static_cast<size_t>(tv[1]),
                                 p + 3 * static_cast<size_t>(tv[2]), o);
        }
        partial[b] = sum;
    });
    double volume = 0.0;
    for (double v : partial) volume += v;
    // Cap: a fan from each loop's centroid; triangle (c, b, a) closes the edge a -> b.
    for (const auto& loop : loops_) {
        dvec3 c(0.0);
        for (const auto& e : loop) c += dvec3(p[3 * e.first], p[3 * e.first + 1], p[3 * e.first + 2]);
        c /= static_cast<double>(loop.size());
        const float cf[3] = {static_cast<float>(c.x), static_cast<float>(c.y), static_cast<float>(c.z)};
        for (const auto& e : loop)
            volume += signed_volume(cf, p + 3 * static_cast<size_t>(e.second), p + 3 * static_cast<size_t>(e.first), o);
    }
    return volume;
}

}  // namespace sd::anatomy
