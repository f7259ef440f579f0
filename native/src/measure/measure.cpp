#include "measure/measure.h"

#include "geometry/mesh_topology.h"
#include "geometry/self_intersection.h"
#include "geometry/cross_section.h"
#include "geometry/mesh.h"

#include <cmath>

namespace sd::measure {

double closed_mesh_volume(int, const float* p, int T, const int32_t* tri) {
    double six_v = 0.0;
    for (int t = 0; t < T; ++t) {
        const float* a = p + 3 * tri[3 * t];
        const float* b = p + 3 * tri[3 * t + 1];
        const float* c = p + 3 * tri[3 * t + 2];
        six_v += glm::dot(dvec3(a[0], a[1], a[2]), glm::cross(dvec3(b[0], b[1], b[2]), dvec3(c[0], c[1], c[2])));
    }
    return six_v / 6.0;
}

int64_t intersecting_pairs(int V, const float* positions, int T, const int32_t* triangles,
                           const std::vector<int32_t>& subset) {
    const anatomy::MeshTopology mesh = anatomy::MeshTopology::build(V, triangles, T, positions);
    std::vector<int32_t> set = subset;
    if (set.empty())
        for (int t = 0; t < T; ++t) set.push_back(t);
    anatomy::CpuCollisionBackend backend;
    backend.set_triangles(mesh, set, positions);
    std::vector<anatomy::TrianglePair> pairs;
    backend.find_pairs(positions, pairs);
    return static_cast<int64_t>(pairs.size());
}

std::vector<double> cross_section_areas(int V, const float* positions, int T, const int32_t* triangles,
                                        const std::vector<dvec3>& points, const std::vector<dvec3>& normals,
                                        double reach) {
    const fit::FitMesh mesh(V, positions, T, triangles);
    std::vector<double> areas;
    for (size_t i = 0; i < points.size(); ++i) {
        const dvec3 n = glm::normalize(normals[i]);
        const fit::PlaneFrame frame(points[i], n, std::abs(n.x) < 0.9 ? dvec3(1, 0, 0) : dvec3(0, 1, 0));
        std::vector<std::vector<dvec2>> polygons;
        for (const fit::SectionLoop& loop : fit::cut_mesh(mesh, points[i], n)) {
            polygons.emplace_back();
            for (const fit::SectionPoint& s : loop.points) polygons.back().push_back(frame.to_plane(s.p));
        }
        const fit::LoopPick pick = fit::pick_loop(polygons, dvec2(0.0), reach);
        areas.push_back(pick.loop < 0 ? 0.0 : std::abs(fit::polygon_area(polygons[pick.loop])));
    }
    return areas;
}

}  // namespace sd::measure
