// The C ABI of the continuous displacement map (sweepdeform_dmap.h). Compiled into the separate library libsweepdeform_dmap.so, which links OpenSubdiv
// and its own (hidden) copy of the core, and talks to libsweepdeform only through rig and
// binding blobs. Its messages go to sd_dmap_last_error(). No exception leaves this file.
#include "sweepdeform/sweepdeform_dmap.h"

#include "abi/guard.h"
#include "dmap/displacement_map.h"
#include "bind/serialize.h"

#include <cmath>
#include <memory>
#include <string>
#include <vector>

struct sd_displacement_map {
    sd::Rig rig;
    sd::DisplacementMap map;
};

struct sd_dmap_binding {
    std::vector<uint8_t> blob;
};

namespace {

using sd::abi::fail;
using sd::abi::guarded;

sd::Rig rig_from_blob(const uint8_t* data, int64_t size) {
    SD_REQUIRE(data && size > 0, "rig blob is NULL or empty");
    return sd::deserialize_rig(data, static_cast<size_t>(size));
}

}  // namespace

extern "C" {

const char* sd_dmap_last_error(void) { return sd::abi::last_error().c_str(); }

sd_status sd_dmap_fit(const uint8_t* rig_blob, int64_t rig_size, const uint8_t* binding_blob, int64_t binding_size,
                      int32_t triangle_count, const int32_t* triangles, int32_t theta_cells, int32_t t_cells_per_span,
                      float smoothing, sd_displacement_map** out_map) {
    return guarded(__func__, [&] {
        SD_REQUIRE(out_map, "out_map is NULL");
        SD_REQUIRE(binding_blob && binding_size > 0, "binding blob is NULL or empty");
        auto m = std::make_unique<sd_displacement_map>();
        m->rig = rig_from_blob(rig_blob, rig_size);
        const sd::Binding binding = sd::deserialize_binding(binding_blob, static_cast<size_t>(binding_size));
        SD_REQUIRE(!std::isnan(smoothing), "smoothing is NaN");
        sd::DisplacementMapOptions options;
        if (theta_cells != 0) options.theta_cells = theta_cells;
        if (t_cells_per_span != 0) options.t_cells_per_span = t_cells_per_span;
        if (smoothing >= 0.0f) options.smoothing = smoothing;
        m->map = sd::DisplacementMap::fit(m->rig, binding, triangle_count, triangles, options);
        *out_map = m.release();
        return SD_OK;
    });
}

void sd_dmap_destroy(sd_displacement_map* map) { delete map; }

int32_t sd_dmap_sweep_count(const sd_displacement_map* map) {
    if (!map) {
        fail(SD_ERR_INVALID_ARGUMENT, "sd_dmap_sweep_count: map is NULL");
        return -1;
    }
    return map->map.sweep_count();
}

sd_status sd_dmap_fit_errors(const sd_displacement_map* map, int32_t sweep_count, int32_t* samples, float* rms,
                             float* max) {
    return guarded(__func__, [&] {
        SD_REQUIRE(map, "map is NULL");
        if (sweep_count != map->map.sweep_count())
            return fail(SD_ERR_MISMATCH, std::string(__func__) + ": sweep_count " + std::to_string(sweep_count) +
                                             " differs from the map's " + std::to_string(map->map.sweep_count()));
        for (int s = 0; s < sweep_count; ++s) {
            const sd::DisplacementFitStats& st = map->map.stats(s);
            if (samples) samples[s] = st.samples;
            if (rms) rms[s] = static_cast<float>(st.rms);
            if (max) max[s] = static_cast<float>(st.max);
        }
        return SD_OK;
    });
}

sd_status sd_dmap_evaluate(const sd_displacement_map* map, int32_t sweep, int32_t count, const float* theta,
                           const float* t, float* displacements, float* rest_points) {
    return guarded(__func__, [&] {
        SD_REQUIRE(map, "map is NULL");
        SD_REQUIRE(sweep >= 0 && sweep < map->map.sweep_count(), "sweep index out of range");
        SD_REQUIRE(count >= 0 && count <= 100'000'000, "count must be in 0..1e8");
        SD_REQUIRE(count == 0 || (theta && t), "theta or t is NULL");
        for (int32_t i = 0; i < count; ++i)
            SD_REQUIRE(std::isfinite(theta[i]) && std::isfinite(t[i]) && t[i] >= 0.0f && t[i] <= 1.0f,
                       "parameter " + std::to_string(i) + " is not finite or t is outside [0, 1]");
        for (int32_t i = 0; i < count; ++i) {
            if (displacements) {
                const sd::dvec3 d = map->map.displacement(sweep, theta[i], t[i]);
                for (int k = 0; k < 3; ++k) displacements[3 * static_cast<size_t>(i) + k] = static_cast<float>(d[k]);
            }
            if (rest_points) {
                const sd::dvec3 p = map->map.rest_point(map->rig, sweep, theta[i], t[i]);
                for (int k = 0; k < 3; ++k) rest_points[3 * static_cast<size_t>(i) + k] = static_cast<float>(p[k]);
            }
        }
        return SD_OK;
    });
}

sd_status sd_dmap_bind(const sd_displacement_map* map, int32_t point_count, const float* positions, float snap,
                       int32_t* out_snapped, sd_dmap_binding** out_binding) {
    return guarded(__func__, [&] {
        SD_REQUIRE(map, "map is NULL");
        SD_REQUIRE(out_binding, "out_binding is NULL");
        SD_REQUIRE(snap >= 0.0f, "snap must be >= 0 (SD_DMAP_SNAP_EXACT .. SD_DMAP_SNAP_SURFACE)");
        SD_REQUIRE(point_count >= 1 && point_count <= 50'000'000, "point_count must be in 1..5e7");
        SD_REQUIRE(positions, "positions is NULL");
        int snapped = 0;
        const sd::Binding b = map->map.bind(map->rig, point_count, positions, static_cast<double>(snap), &snapped);
        auto binding = std::make_unique<sd_dmap_binding>();
        binding->blob = sd::serialize_binding(b);
        if (out_snapped) *out_snapped = snapped;
        *out_binding = binding.release();
        return SD_OK;
    });
}

sd_status sd_dmap_binding_serialize(const sd_dmap_binding* binding, uint8_t* buffer, int64_t capacity,
                                    int64_t* out_size) {
    return guarded(__func__, [&] {
        SD_REQUIRE(binding, "binding is NULL");
        return sd::abi::write_blob(binding->blob, buffer, capacity, out_size);
    });
}

void sd_dmap_binding_destroy(sd_dmap_binding* binding) { delete binding; }

}  // extern "C"
