// The measurement functions of the C ABI (reports and tests).
#include "abi/guard.h"
#include "measure/measure.h"

#include <cmath>

using sd::abi::guarded;

namespace {

/// Validates a triangle mesh given through the ABI. @throws sd::InvalidInput
void check_mesh(int32_t V, const float* positions, int32_t T, const int32_t* triangles) {
    SD_REQUIRE(V >= 3 && V <= 50'000'000 && T >= 1 && T <= 100'000'000, "mesh counts out of range");
    SD_REQUIRE(positions && triangles, "positions or triangles is NULL");
    for (int64_t i = 0; i < 3 * static_cast<int64_t>(V); ++i)
        SD_REQUIRE(std::isfinite(positions[i]) && std::abs(positions[i]) < 1e12f,
                   "vertex " + std::to_string(i / 3) + " has a non-finite or enormous coordinate");
    for (int64_t i = 0; i < 3 * static_cast<int64_t>(T); ++i)
        SD_REQUIRE(triangles[i] >= 0 && triangles[i] < V,
                   "triangle " + std::to_string(i / 3) + " has a vertex index out of range");
}

}  // namespace

extern "C" {

sd_status sd_measure_volume(int32_t vertex_count, const float* positions, int32_t triangle_count,
                            const int32_t* triangles, double* out_volume) {
    return guarded(__func__, [&] {
        check_mesh(vertex_count, positions, triangle_count, triangles);
        SD_REQUIRE(out_volume, "out_volume is NULL");
        *out_volume = sd::measure::closed_mesh_volume(vertex_count, positions, triangle_count, triangles);
        return SD_OK;
    });
}

sd_status sd_measure_intersections(int32_t vertex_count, const float* positions, int32_t triangle_count,
                                   const int32_t* triangles, int32_t subset_count, const int32_t* subset,
                                   int64_t* out_pairs) {
    return guarded(__func__, [&] {
        check_mesh(vertex_count, positions, triangle_count, triangles);
        SD_REQUIRE(out_pairs, "out_pairs is NULL");
        SD_REQUIRE(subset_count >= 0 && subset_count <= triangle_count, "subset_count out of range");
        SD_REQUIRE(subset || subset_count == 0, "subset is NULL");
        std::vector<int32_t> set(subset, subset + subset_count);
        for (int32_t t : set) SD_REQUIRE(t >= 0 && t < triangle_count, "subset triangle out of range");
        *out_pairs = sd::measure::intersecting_pairs(vertex_count, positions, triangle_count, triangles, set);
        return SD_OK;
    });
}

sd_status sd_measure_cross_sections(int32_t vertex_count, const float* positions, int32_t triangle_count,
                                    const int32_t* triangles, int32_t count, const float* points, const float* normals,
                                    float reach, double* out_areas) {
    return guarded(__func__, [&] {
        check_mesh(vertex_count, positions, triangle_count, triangles);
        SD_REQUIRE(count >= 0 && count <= 100000, "count out of range");
        SD_REQUIRE((points && normals && out_areas) || count == 0, "points, normals or out_areas is NULL");
        SD_REQUIRE(std::isfinite(reach) && reach >= 0.0f, "reach must be finite and >= 0");
        std::vector<sd::dvec3> p(count), n(count);
        for (int i = 0; i < count; ++i) {
            p[i] = sd::dvec3(points[3 * i], points[3 * i + 1], points[3 * i + 2]);
            n[i] = sd::dvec3(normals[3 * i], normals[3 * i + 1], normals[3 * i + 2]);
            SD_REQUIRE(std::isfinite(p[i].x + p[i].y + p[i].z) && glm::length(n[i]) > 1e-12 &&
                           std::isfinite(glm::length(n[i])),
                       "plane " + std::to_string(i) + " is not finite or has a zero normal");
        }
        const auto areas =
            sd::measure::cross_section_areas(vertex_count, positions, triangle_count, triangles, p, n, reach);
        for (int i = 0; i < count; ++i) out_areas[i] = areas[i];
        return SD_OK;
    });
}

}  // extern "C"
