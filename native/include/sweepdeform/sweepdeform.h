/*
 * sweepdeform.h — the one public header of libsweepdeform.
 *
 * Sweep-based human deformation (Hyun et al. 2005) behind a small C ABI.
 *
 * The continuous displacement map is another library with its own header,
 * sweepdeform_dmap.h (libsweepdeform_dmap.so).
 *
 * Conventions
 *  - Every function returns an sd_status; on failure the thread-local message from
 *    sd_last_error() says what was wrong, and no output or handle was changed. The
 *    exceptions, which cannot fail or report a failure in their value:
 *      sd_abi_version, sd_library_version, sd_last_error  (the library block: nothing to
 *        check; they return the value itself)
 *      sd_*_destroy  (nothing to report: NULL is accepted and ignored)
 *      sd_rig_bone_count, sd_rig_sweep_count, sd_rig_key_count, sd_binding_vertex_count,
 *      sd_anatomy_joint_count, sd_rig_key_correction_count, sd_rig_correction_count
 *        (a count, or -1 for a NULL handle or an index out of range; sd_rig_key_count,
 *        sd_rig_key_correction_count and sd_anatomy_joint_count then also set
 *        sd_last_error's message)
 *  - The caller owns every array and buffer it passes; the library never hands out memory
 *    of its own except through handles, which the caller destroys. Outputs of a size the
 *    caller cannot know in advance (blobs, the fitting's report) are a size query then a
 *    fill: call with buffer NULL to get *out_size, then with a buffer of that capacity. Arrays are tightly packed, row-major per
 *    element: positions are #V*3 floats (x,y,z), matrices are 16 floats in COLUMN-major
 *    order (the layout of GLM, OpenGL and Blender's Matrix transposed rows), quaternions
 *    are 4 floats (w, x, y, z).
 *  - All geometry (mesh, bones, key ellipses, poses) lives in one common space, the
 *    "armature space" of the character; units are whatever the caller uses (metres in
 *    Blender).
 *  - No C++ exception, assert or abort crosses this boundary. Inputs are validated:
 *    counts, indices in range, finite numbers, unit quaternions (|q| within 1e-3 of 1),
 *    half-axes > 0.
 *  - Handles are opaque. A handle may be used from one thread at a time; different
 *    handles may be used concurrently (an sd_output_check, read-only after creation, from
 *    any number of threads at once).
 */
#ifndef SWEEPDEFORM_H
#define SWEEPDEFORM_H

#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

#if defined(_WIN32)
#define SD_API __declspec(dllexport)
#else
#define SD_API __attribute__((visibility("default")))
#endif

/* Bumped whenever a signature or a struct layout of this header changes, or functions are
 * added (2: the fitting's report is copied into the caller's buffer; joint kinds and
 * parameters renamed; 3: the output check, sd_output_check_*; 4: sd_deform_displaced, sd_mix_shape_keys;
 * 5: sd_compose_offsets, sd_deformer_serialize_joint_volumes, sd_deformer_load_joint_volumes;
 * 6: sd_deform_frame; 7: sd_deformer_set_skin_triangles, sd_deformer_fill_trunk_as). */
#define SD_ABI_VERSION 7

typedef enum sd_status {
    SD_OK = 0,
    SD_ERR_INVALID_ARGUMENT = 1, /* a count, index, number or pointer was invalid */
    SD_ERR_CORRUPT_DATA = 2,     /* a blob failed its magic, version, size or checksum check */
    SD_ERR_OUT_OF_MEMORY = 3,
    SD_ERR_MISMATCH = 4, /* e.g. a binding used with another rig, wrong vertex count */
    SD_ERR_INTERNAL = 5  /* a bug: please report the message */
} sd_status;

typedef struct sd_rig sd_rig;           /* skeleton + sweeps of key ellipses (rest pose) */
typedef struct sd_binding sd_binding;   /* per-vertex binding of one mesh to one rig */
typedef struct sd_deformer sd_deformer; /* a rig + binding + per-frame state */

/* ---- library ---------------------------------------------------------------------- */

/* SD_ABI_VERSION of the loaded library; a caller must refuse a library of another version. */
SD_API int32_t sd_abi_version(void);
/* Library version string, e.g. "0.1.0". Static storage. */
SD_API const char* sd_library_version(void);
/* Message of the last failed call on this thread ("" if none). Valid until the next call. */
SD_API const char* sd_last_error(void);

/* ---- rig ---------------------------------------------------------------------------- */

/*
 * Creates a rig from a rest skeleton.
 *  bone_count   B >= 1
 *  parents      #B, parent bone index or -1 for a root; the hierarchy has no cycles
 *  rest         #B*16, each bone's rest (bind) matrix in armature space, column-major;
 *               the bone's deformation in a pose P is P * rest^-1
 *  heads, tails #B*3, bone head and tail in armature space (tail != head)
 */
SD_API sd_status sd_rig_create(int32_t bone_count, const int32_t* parents, const float* rest, const float* heads,
                               const float* tails, sd_rig** out_rig);
SD_API void sd_rig_destroy(sd_rig* rig);
SD_API sd_status sd_rig_clone(const sd_rig* rig, sd_rig** out_rig);

/*
 * Adds one sweep through K >= 2 key ellipses, ordered from the body outwards
 * (e.g. shoulder, ..., elbow, ..., wrist). Per key k:
 *  centers[3k..]       ellipse center (rest pose)
 *  orientations[4k..]  unit quaternion (w,x,y,z); columns of its rotation matrix are the
 *                      major-axis direction, the minor-axis direction and the plane normal,
 *                      which must point along the sweep (towards key k+1)
 *  half_axes[2k..]     a (along the first column) and b (second column), > 0
 *  bones[k]            the bone the key follows: for an intermediate key the link it sits on,
 *                      for a joint key the lower link (child) of the joint
 *  joint_parents[k]    for a joint key the upper link (parent bone), else -1
 *  fractions[2k..]     (swing, twist) in [0,1] for joint keys: the key turns by this fraction
 *                      of the child's swing and twist relative to the parent (0.5, 0.5 bisects
 *                      the joint); ignored for intermediate keys
 * Key centers must be distinct (chord length > 0). out_sweep_index may be NULL.
 * The last link's keys take the end key's twist as the square of their place along the link
 * (the twist spread 2; the automatic fitting lowers it towards 1 on a mesh with few rings of
 * vertices there, and a rig blob since format version 3 keeps it).
 */
SD_API sd_status sd_rig_add_sweep(sd_rig* rig, int32_t key_count, const float* centers, const float* orientations,
                                  const float* half_axes, const int32_t* bones, const int32_t* joint_parents,
                                  const float* fractions, int32_t* out_sweep_index);
SD_API int32_t sd_rig_bone_count(const sd_rig* rig);
SD_API int32_t sd_rig_sweep_count(const sd_rig* rig);
/* Number of key ellipses of a sweep, or -1 (and an error) for a bad index. */
SD_API int32_t sd_rig_key_count(const sd_rig* rig, int32_t sweep);
/* Reads the key ellipses of a sweep into caller arrays sized as in sd_rig_add_sweep (any may be NULL). */
SD_API sd_status sd_rig_get_keys(const sd_rig* rig, int32_t sweep, float* centers, float* orientations,
                                 float* half_axes, int32_t* bones, int32_t* joint_parents, float* fractions);
/* Rest volume of a sweep, ∫ π a b <N, C'> dt, in units^3. */
SD_API sd_status sd_rig_sweep_rest_volume(const sd_rig* rig, int32_t sweep, double* out_volume);

/*
 * Evaluates a sweep of the rig at its rest pose at `count` parameters u in [0, 1]
 * (0 = first key, 1 = last key, uniform in the spans between keys). Any output may be NULL.
 *  centers   #count*3  C(t)       tangents  #count*3  C'(t) with respect to t = arc-like
 *  normals   #count*3  N(t)       rotations #count*9  R(t) column-major
 *  half_axes #count*2  a(t), b(t)
 */
SD_API sd_status sd_rig_evaluate_sweep(const sd_rig* rig, int32_t sweep, int32_t count, const float* u, float* centers,
                                       float* tangents, float* normals, float* rotations, float* half_axes);

/* Versioned, checksummed byte blob of the rig. Call with buffer NULL to get the size. */
SD_API sd_status sd_rig_serialize(const sd_rig* rig, uint8_t* buffer, int64_t capacity, int64_t* out_size);
/* Rebuilds a rig from a blob; a corrupt or truncated blob is SD_ERR_CORRUPT_DATA. */
SD_API sd_status sd_rig_deserialize(const uint8_t* buffer, int64_t size, sd_rig** out_rig);

/* ---- binding ------------------------------------------------------------------------ */

/*
 * Binds the rest mesh to the rig (Sect. 3.3–3.5).
 *  positions     #V*3 rest positions in armature space
 *  sweep_slots   S >= 0 sweep influences per vertex; sweep_ids #V*S (-1 = unused slot),
 *                sweep_weights #V*S
 *  bone_slots    K >= 0 bone influences per vertex (plain linear blend skinning for parts on
 *                no sweep: hands, feet, head); bone_ids #V*K (-1 unused), bone_weights #V*K
 * For every vertex the weights must be >= 0 with a positive sum; they are normalised.
 */
SD_API sd_status sd_bind(const sd_rig* rig, int32_t vertex_count, const float* positions, int32_t sweep_slots,
                         const int32_t* sweep_ids, const float* sweep_weights, int32_t bone_slots,
                         const int32_t* bone_ids, const float* bone_weights, sd_binding** out_binding);
SD_API void sd_binding_destroy(sd_binding* binding);
SD_API int32_t sd_binding_vertex_count(const sd_binding* binding);
/*
 * Per-vertex binding parameters of the heaviest sweep influence, for display and tests:
 * sweep #V (-1 = bone-driven only), t #V in [0, 1] along the sweep, theta #V radians.
 */
SD_API sd_status sd_binding_get_parameters(const sd_binding* binding, int32_t vertex_count, int32_t* sweep, float* t,
                                           float* theta);
SD_API sd_status sd_binding_serialize(const sd_binding* binding, uint8_t* buffer, int64_t capacity, int64_t* out_size);
SD_API sd_status sd_binding_deserialize(const uint8_t* buffer, int64_t size, sd_binding** out_binding);

/* ---- deformation -------------------------------------------------------------------- */

/* A deformer keeps its own copies of the rig and the binding (which must match). */
SD_API sd_status sd_deformer_create(const sd_rig* rig, const sd_binding* binding, sd_deformer** out_deformer);
SD_API void sd_deformer_destroy(sd_deformer* deformer);

/* Volume preservation (Sect. 4.4): on by default, strength 1 (0 = off, 1 = full). */
SD_API sd_status sd_deformer_set_volume_preservation(sd_deformer* deformer, int32_t enabled, float strength);
/*
 * Per-sweep volume the controller subtracts from the rest volume: its target becomes
 * V0 - offset (the anatomical effects' I_C). offsets #S, units^3, each within
 * [-9, 0.9] x the sweep's rest volume.
 */
SD_API sd_status sd_deformer_set_volume_offsets(sd_deformer* deformer, int32_t sweep_count, const float* offsets);
/*
 * Holds the mesh's volume near each limb joint (docs/math.md, "The mesh's volume at the
 * limb joints"): bends every limb joint of the rig alone through a grid of swings, measures
 * the volume of the bound mesh (triangles #T*3, indices into the binding's vertices), and
 * from then on, each frame, grows the limb sweep's keys at the joint by what the mesh loses
 * at the joint's swing. Takes 25 frames' time per joint. Calling it again measures
 * anew (after an edit of the key ellipses); triangle_count 0 stops it. out_joint_count (may
 * be NULL): the joints held. On error nothing changes.
 */
SD_API sd_status sd_deformer_hold_joint_volumes(sd_deformer* deformer, int32_t vertex_count, int32_t triangle_count,
                                                const int32_t* triangles, int32_t* out_joint_count);
/*
 * The bound mesh's triangles (#T*3 indices into the binding's vertices; triangle_count 0:
 * none). With them a bent trunk (a thick chain, the spine) puts its lost volume back by
 * filling out the skin the pose left nearest its spine, all to one ratio of its rest distance
 * from the spine's bones, instead of growing its sweep's sections (docs/math.md, "The trunk's
 * fill"). Cheap: nothing is measured. On error nothing changes.
 */
SD_API sd_status sd_deformer_set_skin_triangles(sd_deformer* deformer, int32_t vertex_count, int32_t triangle_count,
                                                const int32_t* triangles);
/*
 * Fills the trunk as `source` does (both of the same rig, SD_ERR_MISMATCH otherwise): for a mesh
 * bound through source's displacement map, whose skin is then raised each frame to the level
 * source's skin reaches, so that the two stay together (a copy of source's trunk skin is deformed
 * for it: source's settings at this call). A source without skin triangles: no fill. Replaces
 * sd_deformer_set_skin_triangles and is replaced by it. On error nothing changes.
 */
SD_API sd_status sd_deformer_fill_trunk_as(sd_deformer* deformer, const sd_deformer* source);
/*
 * Holds the joints' volume as `source` does (its measured tables, see above): for a mesh bound
 * through another's displacement map, which then follows the same sweeps. Both deformers must
 * have the same rig (SD_ERR_MISMATCH otherwise). out_joint_count as above.
 */
SD_API sd_status sd_deformer_hold_joint_volumes_of(sd_deformer* deformer, const sd_deformer* source,
                                                   int32_t* out_joint_count);
/*
 * The joints' tables (as measured above) as a versioned, checksummed blob, to keep with the
 * binding: a file opened again then need not bend every limb joint. Call with buffer NULL to
 * get the size. A deformer that holds none gives a blob of no tables.
 */
SD_API sd_status sd_deformer_serialize_joint_volumes(const sd_deformer* deformer, uint8_t* buffer, int64_t capacity,
                                                     int64_t* out_size);
/*
 * Holds the joints' volume by the tables of a blob from sd_deformer_serialize_joint_volumes of a
 * deformer with the same rig (SD_ERR_MISMATCH otherwise); a damaged blob is
 * SD_ERR_CORRUPT_DATA, tables that do not fit the rig SD_ERR_INVALID_ARGUMENT. The tables were
 * measured on the caller's mesh: the caller keeps the blob with the binding it was made for.
 * out_joint_count as above. On error nothing changes.
 */
SD_API sd_status sd_deformer_load_joint_volumes(sd_deformer* deformer, const uint8_t* blob, int64_t size,
                                                int32_t* out_joint_count);

/*
 * Deforms one frame.
 *  pose           #B*16 each bone's posed matrix in armature space (Blender: pose_bone.matrix)
 *  out_positions  #V*3 written with the deformed positions
 * Parallel over vertices; the result does not depend on the number of threads.
 */
SD_API sd_status sd_deform(sd_deformer* deformer, int32_t bone_count, const float* pose, int32_t vertex_count,
                           float* out_positions);

/*
 * sd_deform, and for every vertex the local linear map J of its deformation:
 *  out_frames  #V*9: three blocks of #V*3, block r holding row r of every vertex's 3x3 J
 *              (out_frames[r*3V + 3v + c] = J_v[r][c]), armature space: Σ_sweeps w R(u) R_rest(u)^T (the
 *              rotation of the vertex's cross-section frame from rest to the pose) + Σ_bones w
 *              M_b (linear part), blended with the weights the positions are. A point moved off
 *              the rest surface by d within its cross-section's plane deforms to out + J d; a
 *              caller carries shape keys and earlier deformations along with
 *              out + J (incoming - rest). The rest pose gives the identity.
 */
SD_API sd_status sd_deform_frames(sd_deformer* deformer, int32_t bone_count, const float* pose, int32_t vertex_count,
                                  float* out_positions, float* out_frames);

/*
 * sd_deform, and the displacements of some vertices turned by their local linear maps (the J
 * of sd_deform_frames), J assembled for those vertices only:
 *  moved_count     M >= 0 displaced vertices
 *  moved_vertices  #M their indices, strictly ascending, in [0, V)
 *  displacements   #M*3 armature space, finite, each within ±1e12: d, where a shape key or an
 *                  earlier deformation put the vertex relative to the bound rest
 *  out_positions   #V*3 the deformed rest positions (as sd_deform)
 *  out_turned      #M*3 J d: the displaced vertex deforms to out_positions + out_turned
 * A face's shape keys move a few thousand vertices of a body: they cost those, not 9 floats
 * for every vertex. moved_vertices, displacements and out_turned may be NULL when M is 0.
 */
SD_API sd_status sd_deform_displaced(sd_deformer* deformer, int32_t bone_count, const float* pose, int32_t vertex_count,
                                     int32_t moved_count, const int32_t* moved_vertices, const float* displacements,
                                     float* out_positions, float* out_turned);

/*
 * Relative shape keys mixed as Blender mixes them, as displacements for sd_deform_displaced:
 * d[v] = blocks[0][v] − rest[v] + Σ_t term_values[t] (blocks[key_t][v] − blocks[relative_t][v])
 *  rest          #V*3 the bound mesh's positions (mesh space)
 *  blocks        #block_count*V*3 the keys' positions, block 0 the reference (basis) key
 *  term_blocks   #term_count*2 each active key's block and its relative key's block
 *  term_values   #term_count the keys' values (finite, within ±1e6)
 *  out_moved_count  M, the vertices where d is not zero
 *  out_moved     capacity #V: those vertices, ascending
 *  out_moves     capacity #V*3: their d
 * All positions finite and within ±1e12 (every d is then finite). Single-threaded, one pass.
 */
SD_API sd_status sd_mix_shape_keys(int32_t vertex_count, const float* rest, int32_t block_count, const float* blocks,
                                   int32_t term_count, const int32_t* term_blocks, const float* term_values,
                                   int32_t* out_moved_count, int32_t* out_moved, float* out_moves);

/*
 * A frame's values for the caller's mesh, composed in one pass:
 *   out[v] = base[v] + (positions[v] - rest[v])        (base NULL: positions[v] - rest[v])
 *   then for i < M: out[moved[i]] += turned[i] - displacements[i]   (NULL: += turned[i])
 * each sum one float32 operation in that order, so the result is the same to the bit as the
 * same sums made one array at a time (a mesh's positions from sd_deform_displaced's output:
 * base the mesh, displacements NULL; offsets from the mesh's shape-keyed positions: base NULL,
 * displacements the keys' d).
 *  vertex_count    V >= 0; positions, rest, out: #V*3; base #V*3 or NULL (any values)
 *  moved_count     M in [0, V]; moved_vertices #M strictly ascending in [0, V); turned #M*3,
 *                  displacements #M*3 or NULL; moved_vertices and turned may be NULL when M is 0
 * out may be positions, rest or base. Nothing is written when an argument is refused.
 * Parallel, in blocks of vertices.
 */
SD_API sd_status sd_compose_offsets(int32_t vertex_count, const float* positions, const float* rest, const float* base,
                                    int32_t moved_count, const int32_t* moved_vertices, const float* turned,
                                    const float* displacements, float* out);

/*
 * Sweep volumes of the last sd_deform: rest V0, before volume control, and after it (a trunk
 * whose skin is filled, sd_deformer_set_skin_triangles: with the volume its skin is given).
 * Each array #S (any may be NULL), units^3.
 */
SD_API sd_status sd_deformer_get_volumes(const sd_deformer* deformer, int32_t sweep_count, double* rest, double* before,
                                         double* after);
/* Controller iterations used by each sweep in the last frame (#S). */
SD_API sd_status sd_deformer_get_volume_iterations(const sd_deformer* deformer, int32_t sweep_count,
                                                   int32_t* iterations);

/* ---- the output check (issue 15) ---------------------------------------------------- */

/*
 * A bound on each frame's output: a sweep moves a vertex with its limb, so the vertex's
 * distance to the bones it is skinned to changes at a joint, but not by much. A frame with a
 * vertex farther from its posed bones than `ratio_limit` times its rest distance (shards off
 * the body, a non-finite result) is a pose the sweeps cannot follow; a caller shows the
 * linear blend skinning of the same pose instead (sd_output_check_linear_blend).
 *
 * Per vertex: its two heaviest skin bones (one bone: that bone twice; the earlier slot among
 * equal weights), each as a segment from its head along its matrix's Y axis for its rest
 * length (Blender's bones); the vertex's distance is to the nearer of the two; its rest
 * distance is that distance for the rest positions and the rest pose, raised to
 * floor_share x the rest positions' bounding-box diagonal when below it. The ratio is
 * distance / rest distance (0 on the bone, +inf for a non-finite vertex); a vertex without
 * skin weights is never beyond (ratio 0).
 *
 * The object is read-only after creation: unlike the other handles it may be used from
 * several threads at once.
 */
typedef struct sd_output_check sd_output_check;

/*
 * Creates the check of one bound mesh.
 *  vertex_count     V >= 1; rest_positions #V*3, the rest positions the frames start from
 *  bone_count       B >= 1; rest_pose #B*16 (column-major, invertible), bone_lengths #B (> 0)
 *  skin_slots       S in 0..64; skin_bones #V*S (-1 = unused slot), skin_weights #V*S (>= 0);
 *                   NULL when S = 0 (then no vertex is ever beyond)
 *  floor_share      in [0, 1]: the smallest rest distance, as a share of the body's diagonal
 * All in one space (the armature space of the poses given later).
 */
SD_API sd_status sd_output_check_create(int32_t vertex_count, const float* rest_positions, int32_t bone_count,
                                        const float* rest_pose, const float* bone_lengths, int32_t skin_slots,
                                        const int32_t* skin_bones, const float* skin_weights, float floor_share,
                                        sd_output_check** out_check);
SD_API void sd_output_check_destroy(sd_output_check* check);

/*
 * Checks one frame: `positions` (#V*3, deformed; non-finite values allowed: such a vertex is
 * beyond) for `pose` (#B*16, finite, as for sd_deform) against ratio_limit (finite, > 0).
 *  out_beyond        the number of vertices whose ratio is above ratio_limit: 0 = the frame
 *                    is within the bound
 *  out_worst_ratio   the largest ratio among those vertices (+inf for a non-finite one), 0
 *                    when none (a tiny ratio_limit, e.g. 1e-30, gives the frame's largest)
 *  out_worst_vertex  its vertex (the lowest index among equal ratios), -1 when none
 *  out_worst_bone    that vertex's heaviest skin bone, -1 when none
 *  out_ratios        #V, every vertex's ratio
 * Any output may be NULL. Parallel over vertices; the result does not depend on the number
 * of threads.
 */
SD_API sd_status sd_output_check_run(const sd_output_check* check, int32_t bone_count, const float* pose,
                                     int32_t vertex_count, const float* positions, float ratio_limit,
                                     int32_t* out_beyond, float* out_worst_ratio, int32_t* out_worst_vertex,
                                     int32_t* out_worst_bone, float* out_ratios);

/*
 * The fallback for a frame beyond the bound: the linear blend skinning of the rest positions
 * by `pose` (#B*16) with the skin weights (normalised per vertex), into out_positions (#V*3);
 * a vertex without skin weights stays at rest.
 */
SD_API sd_status sd_output_check_linear_blend(const sd_output_check* check, int32_t bone_count, const float* pose,
                                              int32_t vertex_count, float* out_positions);

/*
 * A frame for the caller's mesh in one parallel pass: sd_deform_displaced (moved_count 0:
 * sd_deform), and as each block of vertices is written, while it is in cache, the output
 * check of its positions and sd_compose_offsets' sums:
 *   out_composed[v] = base[v] + (out_positions[v] - rest[v])   (base NULL: without it)
 *   then out_composed[moved[i]] += out_turned[i] - displacements[i]
 *                                  (subtract_displacements 0: += out_turned[i])
 * The results are those of sd_deform_displaced, sd_output_check_run (ratio_limit, no
 * out_ratios) and sd_compose_offsets called one after the other, to the bit (each step in the
 * same floating-point mode as the separate call's).
 *  check           NULL: no check (out_beyond 0, out_worst_ratio 0, out_worst_vertex and
 *                  out_worst_bone -1); else made for the same vertex and bone counts
 *  rest, base      #V*3 (base may be NULL); out_composed #V*3 (NULL: nothing composed, rest
 *                  and base unused); out_composed may be rest or base, not out_positions
 * Each output pointer to a verdict may be NULL. On a refused argument nothing is written.
 */
SD_API sd_status sd_deform_frame(sd_deformer* deformer, int32_t bone_count, const float* pose, int32_t vertex_count,
                                 int32_t moved_count, const int32_t* moved_vertices, const float* displacements,
                                 float* out_positions, float* out_turned, const sd_output_check* check,
                                 float ratio_limit, int32_t* out_beyond, float* out_worst_ratio,
                                 int32_t* out_worst_vertex, int32_t* out_worst_bone, const float* rest,
                                 const float* base, int32_t subtract_displacements, float* out_composed);

/* ---- measurements (reports and tests) ---------------------------------------------- */

/* Volume enclosed by a closed, outward-oriented triangle mesh (units^3).
 * positions #V*3, triangles #T*3 (indices in [0, V)). */
SD_API sd_status sd_measure_volume(int32_t vertex_count, const float* positions, int32_t triangle_count,
                                   const int32_t* triangles, double* out_volume);
/* Pairs of triangles that intersect and share no vertex, by an exact test, among the
 * `subset_count` triangles listed in `subset` (NULL/0 = all triangles). */
SD_API sd_status sd_measure_intersections(int32_t vertex_count, const float* positions, int32_t triangle_count,
                                          const int32_t* triangles, int32_t subset_count, const int32_t* subset,
                                          int64_t* out_pairs);
/* Cross-section areas: for each plane i (points #count*3, normals #count*3) the area of the
 * cut loop surrounding points[i] (else the nearest loop within `reach`), 0 when none. */
SD_API sd_status sd_measure_cross_sections(int32_t vertex_count, const float* positions, int32_t triangle_count,
                                           const int32_t* triangles, int32_t count, const float* points,
                                           const float* normals, float reach, double* out_areas);

/* ---- automatic fitting (Sect. 3.2, 3.5) ---- */

/*
 * A fitted sweep rig for a rigged character, made in one call: sweep chains found from the
 * skeleton (torso, neck, arms, legs), key ellipses fitted to the mesh's cross-sections at
 * the joints and along the links, and per-vertex weights for sd_bind (sweeps where the
 * chains are, the character's own bones for hands, feet and head).
 */
typedef struct sd_fit_result sd_fit_result;

/*
 * Fits a rig. Everything in armature space, any unit (tolerances are relative).
 *  vertex_count V >= 3, positions #V*3; triangle_count T >= 1, triangles #T*3 vertex indices
 *  bone_count B, parents, rest, heads, tails  as in sd_rig_create
 *  bone_names    #B NUL-terminated names, or NULL (entries may be NULL); hints only
 *  skin_slots    S >= 0 influences per vertex; skin_bones #V*S (-1 unused), skin_weights #V*S
 *                (>= 0). S = 0 (arrays NULL): the regions come from geometry alone.
 *  keys_per_link intermediate key ellipses per link, 0..16 (2 is the usual choice)
 *  chain_count   0: find the chains automatically. Otherwise the chains, from the body
 *                outwards: chain c has bones chain_bones[chain_offsets[c] ..
 *                chain_offsets[c+1]), each bone below the one before it;
 *                chain_offsets #chain_count+1, starting at 0 and increasing.
 * A chain that cannot be fitted gets no sweep (its bones then drive their vertices), which
 * the report says; it is an error only when no chain can be fitted.
 */
SD_API sd_status sd_fit_rig(int32_t vertex_count, const float* positions, int32_t triangle_count,
                            const int32_t* triangles, int32_t bone_count, const int32_t* parents, const float* rest,
                            const float* heads, const float* tails, const char* const* bone_names, int32_t skin_slots,
                            const int32_t* skin_bones, const float* skin_weights, int32_t keys_per_link,
                            int32_t chain_count, const int32_t* chain_offsets, const int32_t* chain_bones,
                            sd_fit_result** out_result);
SD_API void sd_fit_result_destroy(sd_fit_result* result);
/* A new rig (the skeleton and one sweep per fitted chain); the caller destroys it. */
SD_API sd_status sd_fit_result_rig(const sd_fit_result* result, sd_rig** out_rig);
/* Slot counts of the weights below (either pointer may be NULL). */
SD_API sd_status sd_fit_result_slot_counts(const sd_fit_result* result, int32_t* sweep_slots, int32_t* bone_slots);
/*
 * The binding weights, ready for sd_bind with the same slot counts: sweep_ids/sweep_weights
 * #V*sweep_slots, bone_ids/bone_weights #V*bone_slots. Slot counts may exceed those of
 * sd_fit_result_slot_counts (extra slots get id -1, weight 0), not fall short of them.
 */
SD_API sd_status sd_fit_result_weights(const sd_fit_result* result, int32_t vertex_count, int32_t sweep_slots,
                                       int32_t* sweep_ids, float* sweep_weights, int32_t bone_slots, int32_t* bone_ids,
                                       float* bone_weights);
/*
 * The fitting report, JSON text (UTF-8), copied into the caller's buffer: *out_size is its
 * size in bytes including the terminating NUL; with buffer NULL only *out_size is written,
 * else capacity must be at least that size. The report holds
 * mesh statistics (components, border edges, non-manifold faces), the body axes, per chain
 * its kind, bones, sweep index (-1 if it failed, with "error"), and per key ellipse its role,
 * bone, center, normal, half-axes, the area of the cross-section it was fitted to and of the
 * ellipse, fit RMS, the share of the section that belonged to the chain, fallbacks and notes;
 * the regions' counts (vertices bound, blended, rigid) and warnings.
 */
SD_API sd_status sd_fit_result_report(const sd_fit_result* result, char* buffer, int64_t capacity, int64_t* out_size);

/* ---- anatomical effects (Sect. 4.3, 4.4) ---- */

/*
 * On top of a deformer: skin folding where the skin intersects itself near joints (collision
 * detection with a BVH and exact triangle tests, bisecting planes, relaxing), bone
 * protrusion (olecranon, patella, or a mesh of the caller's), muscle bulge (biceps, calf),
 * and I_C, the volume they add, fed back to the deformer's volume control as its target
 * V0 - I_C; plus a volume restoration that holds each bent limb's skin at its rest volume.
 * One sd_anatomy per bound mesh; it keeps copies of what it needs. Like the other handles it
 * is used from one thread at a time; its results do not depend on the number of threads.
 * It carries state from frame to frame (I_C, the restoration's push): a pose reached after
 * others can differ slightly from the same pose as the first frame (mode 2 below, or mode 0
 * with restore 0, make every frame depend on its pose only).
 */
typedef struct sd_anatomy sd_anatomy;

typedef enum sd_joint_kind {
    SD_JOINT_KIND_GENERIC = 0, /* folding only: shoulder (armpit), hip (groin), neck */
    SD_JOINT_KIND_ELBOW = 1,   /* also an olecranon proxy on the forearm and a biceps */
    SD_JOINT_KIND_KNEE = 2     /* also a patella proxy and a calf muscle on the shin */
} sd_joint_kind;

/* Per-joint effect switches, a bit mask (all on when a joint is added). */
#define SD_EFFECT_FOLDING 1
#define SD_EFFECT_PROTRUSION 2
#define SD_EFFECT_BULGE 4

typedef enum sd_joint_parameter {
    SD_JOINT_PARAM_PROTRUSION_STRENGTH = 0, /* 0..2 (1): scales the push out of a bone proxy */
    SD_JOINT_PARAM_PROTRUSION_FALLOFF = 1,  /* >= 0 (0 = automatic): radius of its smooth falloff, units */
    SD_JOINT_PARAM_BULGE_STRENGTH = 2,      /* 0..1 (0.15): outward push at full flexion, share of the local radius */
    SD_JOINT_PARAM_BULGE_FALLOFF = 3,   /* 0.05..0.5 (0.35): width of the muscle's smooth edge, share of its extent */
    SD_JOINT_PARAM_FOLDING_FALLOFF = 4, /* >= 0 (0 = automatic): radius of the folding falloff, units */
    SD_JOINT_PARAM_FOLDING_MARGIN = 5,  /* >= 0 (0 = automatic): gap kept between folded skin, units */
    SD_JOINT_PARAM_REGION_RADIUS = 6    /* >= 0 (0 = automatic): collision region around the joint at rest */
} sd_joint_parameter;

/*
 * Creates the anatomy layer for the mesh bound by `binding` (to `rig`: the pair a deformer
 * is created from). triangles #T*3 vertex indices in [0, V), T >= 1.
 */
SD_API sd_status sd_anatomy_create(const sd_rig* rig, const sd_binding* binding, int32_t triangle_count,
                                   const int32_t* triangles, sd_anatomy** out_anatomy);
SD_API void sd_anatomy_destroy(sd_anatomy* anatomy);
/*
 * Adds the joint whose lower link is `lower_bone` (the rig must have a joint key ellipse
 * with that bone and a joint parent; the parent is the upper link). flexion_direction #3
 * (armature space, rest): where the lower link moves when the joint flexes — the front for
 * an elbow, the back for a knee; required for elbows and knees, may be NULL for generic
 * joints. out_joint (may be NULL) receives the joint's index.
 */
SD_API sd_status sd_anatomy_add_joint(sd_anatomy* anatomy, int32_t lower_bone, int32_t kind,
                                      const float* flexion_direction, int32_t* out_joint);
/* Number of joints, or -1 (and an error) for NULL. */
SD_API int32_t sd_anatomy_joint_count(const sd_anatomy* anatomy);
SD_API sd_status sd_anatomy_set_joint_effects(sd_anatomy* anatomy, int32_t joint, int32_t effects);
SD_API sd_status sd_anatomy_get_joint_effects(const sd_anatomy* anatomy, int32_t joint, int32_t* effects);
SD_API sd_status sd_anatomy_set_joint_parameter(sd_anatomy* anatomy, int32_t joint, int32_t parameter, float value);
SD_API sd_status sd_anatomy_get_joint_parameter(const sd_anatomy* anatomy, int32_t joint, int32_t parameter,
                                                float* value);
/*
 * Replaces the joint's bone proxies by a mesh of the caller's: positions #N*3 (armature
 * space, rest pose), triangles #F*3, closed and consistently oriented, star-shaped about its
 * volume centroid; it follows `fraction` in [0, 1] of the joint's rotation (1: rigidly with
 * the lower link, 0.5: with the joint's bisector).
 */
SD_API sd_status sd_anatomy_set_joint_proxy(sd_anatomy* anatomy, int32_t joint, int32_t vertex_count,
                                            const float* positions, int32_t triangle_count, const int32_t* triangles,
                                            float fraction);
/*
 * How I_C (the volume bulge, protrusion and folding added, per sweep) reaches the volume
 * control. mode 0: not at all; 1 (default): I_C of a frame sets the next frame's target (one
 * pass, as in the paper; approached with gain 0.6 and bounded to 15 % of the sweep's volume);
 * 2: I_C put back in the same frame (results depend on the pose only): one pass of the
 * effects, the sweeps evaluated again with the frame's I_C and their change added, the
 * restoration started from nothing and trimmed twice. restore != 0 (default): the skin of each sweep that owns an elbow or a
 * knee is held at its rest mesh volume by a smooth outward push around the joint on its
 * extensor half, trimmed after folding in every frame by the measured deficit (what the
 * sweep integral cannot see: the displacement map's own volume change at deep bends, volume
 * the controller puts elsewhere); folding's loss then stays out of I_C.
 */
SD_API sd_status sd_anatomy_set_volume_feedback(sd_anatomy* anatomy, int32_t mode, int32_t restore);
/* Folding passes per frame (detection after each), 1..64 (default 10). */
SD_API sd_status sd_anatomy_set_folding_iterations(sd_anatomy* anatomy, int32_t iterations);
/*
 * Applies the effects to `positions` (#V*3, in place): what sd_deform wrote for `pose`
 * (#B*16). With a deformer (may be NULL) I_C is measured and handed to it as its volume
 * offsets as the feedback mode says.
 */
SD_API sd_status sd_anatomy_apply(sd_anatomy* anatomy, sd_deformer* deformer, int32_t bone_count, const float* pose,
                                  int32_t vertex_count, float* positions);
/* sd_deform followed by the effects and the volume feedback, in one call. */
SD_API sd_status sd_deform_with_anatomy(sd_deformer* deformer, sd_anatomy* anatomy, int32_t bone_count,
                                        const float* pose, int32_t vertex_count, float* out_positions);

/* Figures of the last frame, by index (times in milliseconds, volumes in units^3). */
typedef enum sd_anatomy_stat {
    SD_STAT_MS_SWEEPS = 0,
    SD_STAT_MS_BULGE = 1,
    SD_STAT_MS_PROTRUSION = 2,
    SD_STAT_MS_COLLISION = 3,
    SD_STAT_MS_FOLDING = 4,
    SD_STAT_MS_VOLUME = 5,
    SD_STAT_MS_TOTAL = 6,
    SD_STAT_COLLISION_TRIANGLES = 7, /* triangles in the enabled joints' regions */
    SD_STAT_PAIRS_BEFORE = 8,        /* intersecting pairs before folding */
    SD_STAT_PAIRS_AFTER = 9,         /* left after folding (0 unless the passes ran out) */
    SD_STAT_FOLDING_ITERATIONS = 10,
    SD_STAT_FOLDING_REGIONS = 11,
    SD_STAT_BULGE_VERTICES = 12,
    SD_STAT_PROTRUSION_VERTICES = 13,
    SD_STAT_FOLDED_VERTICES = 14,
    SD_STAT_FALLOFF_VERTICES = 15,
    SD_STAT_RELAXED_VERTICES = 16,
    SD_STAT_MAX_BULGE = 17, /* largest displacement, units */
    SD_STAT_MAX_PROTRUSION = 18,
    SD_STAT_MAX_FOLD_DEPTH = 19,
    SD_STAT_VOLUME_CHANGE = 20,  /* sum of I_C handed to the deformer */
    SD_STAT_EFFECTS_VOLUME = 21, /* volume bulge, protrusion and folding added */
    SD_STAT_PASSES = 22,
    SD_STAT_RESTORED_VOLUME = 23, /* volume the restoration added */
    SD_STAT_COUNT = 24
} sd_anatomy_stat;
/* Writes the first `count` (0..SD_STAT_COUNT) figures into values. */
SD_API sd_status sd_anatomy_get_stats(const sd_anatomy* anatomy, int32_t count, double* values);
/* I_C per sweep of the last frame (#S, units^3). */
SD_API sd_status sd_anatomy_get_volume_offsets(const sd_anatomy* anatomy, int32_t sweep_count, double* offsets);
/*
 * Exact count of intersecting triangle pairs (sharing no vertex) among the triangles of the
 * joints whose folding is on, for `positions` (#V*3): a check, independent of the folding.
 */
SD_API sd_status sd_anatomy_count_intersections(sd_anatomy* anatomy, int32_t vertex_count, const float* positions,
                                                int32_t* out_pairs);

/* ---- key-ellipse editing (Sect. 4.2) ---- */

/*
 * Pose-space corrections of key ellipses: the artist moves, turns or scales a key ellipse
 * while the character is in some pose, and the edit is stored as a correction keyed by the
 * key's JOINT ANGLE there, so it acts near that angle only.
 *
 * The joint of a key: for a joint key its own (joint_parent = upper link, bone = lower
 * link); for an intermediate key the joint key of its sweep nearest along the rest curve (a
 * tie goes to the one nearer the body); in a sweep without joint keys, the key's bone and
 * that bone's parent (a root bone has no joint: its angle is always 0). The JOINT ANGLE is
 * the angle, in radians in [0, pi], between the directions (tail - head) of the two links,
 * each turned by its bone's rotation in the pose: 0 for a straight limb, about 2.6 for an
 * elbow bent by 150 degrees from straight. It ignores twist.
 *
 * A correction is (angle, values[8], muted) with
 *   values[0..2]  center offset, along the key's own axes (major, minor, normal) in the pose
 *   values[3..5]  small rotation, a rotation vector (axis * radians) in the key's frame
 *   values[6..7]  factors of the half-axes a and b (multiplicative, 1 = unchanged)
 * Limits: angle in [0, pi]; |offset| <= 10 x the key's larger rest half-axis; |rotation| <=
 * pi/2; factors in [0.1, 10]; at most 64 corrections per key. The identity is all zero but
 * values[6] = values[7] = 1.
 *
 * In a pose, each key's correction is the interpolation over its joint angle of its
 * non-muted corrections (closer than 1e-3 rad: averaged) plus, unless one of them lies
 * within 1e-3 rad of the key's rest angle, the rest angle with no correction: a monotone
 * cubic Hermite spline per value (offset, rotation vector, log of the factors) with
 * Fritsch-Carlson slopes inside, zero slope at the first and last sample and constant
 * beyond them. So a correction made at full flexion leaves the rest pose exactly as it was,
 * and one made at the rest angle shifts every pose. It is applied to the key placed by
 * Sect. 4.1 (center + R offset, orientation R exp(rotation), a and b times the factors),
 * before C(t) and Q(t) are built; the volume controller (Sect. 4.4) starts from the scaled
 * half-axes and keeps what the scaling added (its target is the corrected rest volume V0
 * plus the volume the factors add in that pose). V0 is the rig's rest volume unless a
 * correction lies at a rest angle: then it is the volume of the rest pose with those
 * corrections' offsets and rotations.
 *
 * Corrections are part of the rig and of its blob (format version 2 and on; version 1 blobs
 * still load), but not of its fingerprint: a binding made before an edit stays valid. A deformer
 * copies the rig: give it the edited corrections with sd_deformer_set_rig_corrections (or
 * create it again). Correction lists are sorted by angle; indices refer to that order.
 */

/* The joint a key's corrections are keyed by: its bones (parent -1: none) and its rest angle.
 * Any output may be NULL. */
SD_API sd_status sd_rig_key_joint(const sd_rig* rig, int32_t sweep, int32_t key, int32_t* parent_bone,
                                  int32_t* child_bone, float* rest_angle);
/* The key's joint angle in a pose (#B*16 as for sd_deform; NULL = the rest pose). */
SD_API sd_status sd_rig_key_joint_angle(const sd_rig* rig, int32_t sweep, int32_t key, int32_t bone_count,
                                        const float* pose, float* out_angle);
/* Adds a correction, or replaces the one within 1e-3 rad of `angle`. values #8 as above.
 * out_index (may be NULL) receives its index in the key's sorted list. */
SD_API sd_status sd_rig_set_key_correction(sd_rig* rig, int32_t sweep, int32_t key, float angle, const float* values,
                                           int32_t muted, int32_t* out_index);
SD_API sd_status sd_rig_remove_key_correction(sd_rig* rig, int32_t sweep, int32_t key, int32_t index);
SD_API sd_status sd_rig_mute_key_correction(sd_rig* rig, int32_t sweep, int32_t key, int32_t index, int32_t muted);
/* Number of corrections of a key, or -1 (and an error) for a bad index. */
SD_API int32_t sd_rig_key_correction_count(const sd_rig* rig, int32_t sweep, int32_t key);
/* A key's corrections: count must be sd_rig_key_correction_count; angles #count,
 * values #count*8, muted #count (any may be NULL). */
SD_API sd_status sd_rig_get_key_corrections(const sd_rig* rig, int32_t sweep, int32_t key, int32_t count, float* angles,
                                            float* values, int32_t* muted);
/* The interpolated correction of a key at a joint angle (values #8). */
SD_API sd_status sd_rig_key_correction_at(const sd_rig* rig, int32_t sweep, int32_t key, float angle, float* values);
/* All corrections of the rig, ordered by sweep, key and angle (-1 for a NULL rig). */
SD_API int32_t sd_rig_correction_count(const sd_rig* rig);
/* count must be sd_rig_correction_count; sweeps, keys, angles #count, values #count*8,
 * muted #count (any may be NULL). */
SD_API sd_status sd_rig_get_corrections(const sd_rig* rig, int32_t count, int32_t* sweeps, int32_t* keys, float* angles,
                                        float* values, int32_t* muted);
/* Replaces every correction of the rig (count 0 removes them all), all or nothing; arrays as
 * in sd_rig_get_corrections (muted may be NULL: none muted). */
SD_API sd_status sd_rig_set_corrections(sd_rig* rig, int32_t count, const int32_t* sweeps, const int32_t* keys,
                                        const float* angles, const float* values, const int32_t* muted);
/*
 * The key ellipses of a sweep in a pose (NULL = rest): key_count must be the sweep's;
 * centers #K*3, orientations #K*4 (w,x,y,z), half_axes #K*2 (before volume control), angles
 * #K the joint angles; any may be NULL. corrected = 0: Sect. 4.1's placement only; 1: with
 * the corrections.
 */
SD_API sd_status sd_rig_pose_keys(const sd_rig* rig, int32_t sweep, int32_t bone_count, const float* pose,
                                  int32_t corrected, int32_t key_count, float* centers, float* orientations,
                                  float* half_axes, float* angles);
/* The corrected sweep in a pose (NULL = rest), before volume control, at `count` parameters
 * u in [0, 1] as in sd_rig_evaluate_sweep: centers #count*3, rotations #count*9
 * (column-major), half_axes #count*2; any may be NULL. The centers are the trajectory the
 * deformer gives the skin (a twisted limb's turns with its twist about the bone; a limb's
 * tangent at a joint bent up to a right angle shortened). */
SD_API sd_status sd_rig_evaluate_posed_sweep(const sd_rig* rig, int32_t sweep, int32_t bone_count, const float* pose,
                                             int32_t count, const float* u, float* centers, float* rotations,
                                             float* half_axes);
/* Replaces the corrections of the deformer's copy of the rig (as sd_rig_set_corrections).
 * Cheap, for live edits and animated corrections; the binding stays valid. */
SD_API sd_status sd_deformer_set_rig_corrections(sd_deformer* deformer, int32_t count, const int32_t* sweeps,
                                                 const int32_t* keys, const float* angles, const float* values,
                                                 const int32_t* muted);

#ifdef __cplusplus
}
#endif
#endif /* SWEEPDEFORM_H */
