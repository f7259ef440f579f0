/*
 * sweepdeform_dmap.h — the public header of libsweepdeform_dmap, the continuous displacement
 * map (Sect. 3.4).
 *
 * The conventions of sweepdeform.h hold (status codes, caller-owned buffers, no exception
 * across the boundary, one thread per handle), with two differences: failures are reported
 * through sd_dmap_last_error(), this library's own thread-local message; and
 * sd_dmap_last_error, sd_dmap_destroy, sd_dmap_binding_destroy and sd_dmap_sweep_count do not
 * return an sd_status (the message itself; nothing to report, NULL is accepted; a count, or
 * -1 and a message for a NULL map). It includes sweepdeform.h for sd_status and SD_API only:
 * the library needs no libsweepdeform.so.
 */
#ifndef SWEEPDEFORM_DMAP_H
#define SWEEPDEFORM_DMAP_H

#include "sweepdeform/sweepdeform.h"

#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

/*
 * The continuous displacement map d(θ, t) of a bound mesh: per sweep, the displacement of
 * the skin from the moving ellipse in the sweep's local frame (x, y along the ellipse's
 * axes, z along the sweep; the out-of-plane part is kept) as a smooth bicubic B-spline over
 * a regular (θ, t) control grid, periodic in θ and open in t, evaluated with OpenSubdiv. With
 * it, geometry that was never fitted (a subdivided or retopologised mesh of the same body, a
 * point cloud) is bound without re-fitting: weights from the closest point of the fitted
 * mesh, (θ, t) by the binding's plane search, local coordinates from the map.
 *
 * These functions live in the SEPARATE library libsweepdeform_dmap.so (it links OpenSubdiv;
 * libsweepdeform.so does not), so a host loads OpenSubdiv only when it uses the map. They
 * exchange rigs and bindings as the blobs of sd_rig_serialize / sd_binding_serialize (the
 * two libraries share no handles), and report failures through sd_dmap_last_error(), not
 * sd_last_error(). t is the sweep's global parameter in [0, 1], uniform per span, as in
 * sd_rig_evaluate_sweep; θ in radians.
 */
typedef struct sd_displacement_map sd_displacement_map;

/* sd_dmap_bind's snap: no point takes the map's surface / every point does / the default. */
#define SD_DMAP_SNAP_EXACT 0.0f
#define SD_DMAP_SNAP_SURFACE 1e30f
#define SD_DMAP_SNAP_DEFAULT 0.1f

/* Message of the last failed sd_dmap_* call on this thread ("" if none). */
SD_API const char* sd_dmap_last_error(void);

/*
 * Fits the map of a bound mesh.
 *  rig_blob, binding_blob  blobs of the rig and of a binding made with it (sd_bind)
 *  triangle_count, triangles  the bound mesh's triangles (#T*3 vertex indices)
 *  theta_cells       control points around each sweep, 4..256 (0 = default 24)
 *  t_cells_per_span  control intervals along each span, 1..64 (0 = default 3)
 *  smoothing         bending weight relative to the data, >= 0 (negative = default 1e-3)
 */
SD_API sd_status sd_dmap_fit(const uint8_t* rig_blob, int64_t rig_size, const uint8_t* binding_blob,
                             int64_t binding_size, int32_t triangle_count, const int32_t* triangles,
                             int32_t theta_cells, int32_t t_cells_per_span, float smoothing,
                             sd_displacement_map** out_map);
SD_API void sd_dmap_destroy(sd_displacement_map* map);
SD_API int32_t sd_dmap_sweep_count(const sd_displacement_map* map);
/* Fit residuals per sweep at its own samples (#S each, any may be NULL): sample counts,
 * weighted RMS and max of |d_V - d(θ_V, t_V)| in the rig's units. */
SD_API sd_status sd_dmap_fit_errors(const sd_displacement_map* map, int32_t sweep_count, int32_t* samples, float* rms,
                                    float* max);
/* d(θ_i, t_i) of one sweep for `count` parameter pairs: displacements #count*3 (local frame)
 * and/or rest_points #count*3 (armature space, S(θ,t) + R(t) d(θ,t)); either may be NULL. */
SD_API sd_status sd_dmap_evaluate(const sd_displacement_map* map, int32_t sweep, int32_t count, const float* theta,
                                  const float* t, float* displacements, float* rest_points);
/*
 * Binds `point_count` rest points (#N*3, armature space; no connectivity needed) through the
 * map (which keeps the rig it was fitted with): weights from the closest point of the fitted
 * mesh, (θ, t) per sweep by the plane search of sd_bind. Each sweep influence then takes the
 * map's smooth surface point at its (θ, t) if that lies within snap x min(a(t), b(t)) of the
 * point's own offset, else keeps its own (folds and caps where d is not single-valued).
 * SD_DMAP_SNAP_EXACT keeps every point where it is; SD_DMAP_SNAP_SURFACE moves every point
 * onto the map's surface. out_snapped (may be NULL) receives how many influences took the
 * map's point. The binding comes back as a handle whose blob (sd_dmap_binding_serialize)
 * sd_binding_deserialize() of libsweepdeform reads; it is made for the same rig as the
 * binding the map was fitted from (it carries that binding's rig fingerprint), so it deforms
 * with that rig's handle.
 */
typedef struct sd_dmap_binding sd_dmap_binding;
SD_API sd_status sd_dmap_bind(const sd_displacement_map* map, int32_t point_count, const float* positions, float snap,
                              int32_t* out_snapped, sd_dmap_binding** out_binding);
/* The binding's blob, for sd_binding_deserialize() of libsweepdeform, into the caller's
 * buffer: call with buffer NULL to get *out_size, then with a buffer of that capacity (as
 * sd_binding_serialize). */
SD_API sd_status sd_dmap_binding_serialize(const sd_dmap_binding* binding, uint8_t* buffer, int64_t capacity,
                                           int64_t* out_size);
SD_API void sd_dmap_binding_destroy(sd_dmap_binding* binding);

#ifdef __cplusplus
}
#endif

#endif /* SWEEPDEFORM_DMAP_H */
