/*
 * A C99 program on the public header only: a two-bone arm (upper arm and forearm along +x,
 * a cylinder of radius 0.1 around them), one sweep of five key ellipses with a joint key at
 * the elbow, bound and deformed at rest and with the elbow bent by 90 degrees.
 *
 * It checks what a caller can see: at rest the mesh comes back where it was; bent, the far end
 * of the forearm follows the forearm bone (its ring centre moves from (2,0,0) to (1,1,0)), the
 * shoulder end stays, and the volume control keeps the sweep's volume near its rest volume.
 * Exit status 0 when every check holds; it prints what it measured either way.
 *
 * Build: cc -std=c99 two_bone_arm.c -I native/include -lsweepdeform -lm (CTest runs it).
 */
#include "sweepdeform/sweepdeform.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define BONES 2
#define KEYS 5
#define RINGS 21 /* x = 0, 0.1, ..., 2 */
#define AROUND 16
#define VERTICES (RINGS * AROUND)

static const double kPi = 3.14159265358979323846;
static int failures = 0;

static void check(int ok, const char* what, double measured, double limit) {
    printf("%-52s %12.3g (limit %g) %s\n", what, measured, limit, ok ? "ok" : "FAILED");
    if (!ok) ++failures;
}

/* Stops on a failed call, printing the library's message. */
static void require(sd_status status, const char* call) {
    if (status == SD_OK) return;
    fprintf(stderr, "%s failed (status %d): %s\n", call, (int)status, sd_last_error());
    exit(1);
}

/* A translation by (x, y, z) times a rotation by `angle` about +z, column-major. */
static void matrix(float* m, double angle, float x, float y, float z) {
    const float c = (float)cos(angle), s = (float)sin(angle);
    const float values[16] = {c, s, 0, 0, -s, c, 0, 0, 0, 0, 1, 0, x, y, z, 1};
    memcpy(m, values, sizeof values);
}

/* The centre of one ring of the cylinder in `positions`. */
static void ring_centre(const float* positions, int ring, double* centre) {
    int i, k;
    for (k = 0; k < 3; ++k) centre[k] = 0.0;
    for (i = 0; i < AROUND; ++i)
        for (k = 0; k < 3; ++k) centre[k] += positions[3 * (ring * AROUND + i) + k] / (double)AROUND;
}

static double distance(const double* a, const double* b) {
    return sqrt((a[0] - b[0]) * (a[0] - b[0]) + (a[1] - b[1]) * (a[1] - b[1]) + (a[2] - b[2]) * (a[2] - b[2]));
}

int main(void) {
    /* Skeleton: bone 0 (upper arm) from (0,0,0) to (1,0,0), bone 1 (forearm) on to (2,0,0). */
    const int32_t parents[BONES] = {-1, 0};
    const float heads[BONES * 3] = {0, 0, 0, 1, 0, 0};
    const float tails[BONES * 3] = {1, 0, 0, 2, 0, 0};
    float rest[BONES * 16];
    /* Key ellipses at x = 0, 0.5, 1 (the elbow's joint key), 1.5, 2. The quaternion
     * (0.5, 0.5, 0.5, 0.5) turns the ellipse's axes to (y, z) and its normal to +x. */
    float centers[KEYS * 3], orientations[KEYS * 4], half_axes[KEYS * 2], fractions[KEYS * 2];
    const int32_t bones[KEYS] = {0, 0, 1, 1, 1};
    const int32_t joint_parents[KEYS] = {-1, -1, 0, -1, -1};
    float mesh[VERTICES * 3], deformed[VERTICES * 3], pose[BONES * 16];
    int32_t sweep_ids[VERTICES];
    float sweep_weights[VERTICES];
    sd_rig* rig = NULL;
    sd_binding* binding = NULL;
    sd_deformer* deformer = NULL;
    double rest_volume = 0.0, before = 0.0, after = 0.0, error = 0.0, centre[3];
    const double wrist_bent[3] = {1.0, 1.0, 0.0}, shoulder[3] = {0.0, 0.0, 0.0};
    int k, r, i;

    if (sd_abi_version() != SD_ABI_VERSION) {
        fprintf(stderr, "library ABI %d, header ABI %d\n", (int)sd_abi_version(), SD_ABI_VERSION);
        return 1;
    }
    matrix(rest, 0.0, 0, 0, 0);
    matrix(rest + 16, 0.0, 1, 0, 0);
    require(sd_rig_create(BONES, parents, rest, heads, tails, &rig), "sd_rig_create");
    for (k = 0; k < KEYS; ++k) {
        centers[3 * k] = 0.5f * (float)k;
        centers[3 * k + 1] = centers[3 * k + 2] = 0.0f;
        for (i = 0; i < 4; ++i) orientations[4 * k + i] = 0.5f;
        half_axes[2 * k] = half_axes[2 * k + 1] = 0.1f;
        fractions[2 * k] = fractions[2 * k + 1] = 0.5f;
    }
    require(sd_rig_add_sweep(rig, KEYS, centers, orientations, half_axes, bones, joint_parents, fractions, NULL),
            "sd_rig_add_sweep");

    /* The skin: a cylinder of radius 0.1 on the sweep, every vertex on sweep 0 alone. */
    for (r = 0; r < RINGS; ++r)
        for (i = 0; i < AROUND; ++i) {
            const double theta = 2.0 * kPi * i / AROUND;
            float* p = mesh + 3 * (r * AROUND + i);
            p[0] = 0.1f * (float)r;
            p[1] = (float)(0.1 * cos(theta));
            p[2] = (float)(0.1 * sin(theta));
            sweep_ids[r * AROUND + i] = 0;
            sweep_weights[r * AROUND + i] = 1.0f;
        }
    require(sd_bind(rig, VERTICES, mesh, 1, sweep_ids, sweep_weights, 0, NULL, NULL, &binding), "sd_bind");
    require(sd_deformer_create(rig, binding, &deformer), "sd_deformer_create");

    /* At rest the skin stays where it is. */
    require(sd_deform(deformer, BONES, rest, VERTICES, deformed), "sd_deform");
    for (i = 0; i < 3 * VERTICES; ++i)
        if (fabs(deformed[i] - mesh[i]) > error) error = fabs(deformed[i] - mesh[i]);
    check(error < 1e-4, "rest pose: largest move of a vertex", error, 1e-4);

    /* The elbow bent by 90 degrees about +z. */
    matrix(pose, 0.0, 0, 0, 0);
    matrix(pose + 16, kPi / 2.0, 1, 0, 0);
    require(sd_deform(deformer, BONES, pose, VERTICES, deformed), "sd_deform");
    ring_centre(deformed, RINGS - 1, centre);
    check(distance(centre, wrist_bent) < 1e-3, "bent: wrist ring centre from (1, 1, 0)", distance(centre, wrist_bent),
          1e-3);
    ring_centre(deformed, 0, centre);
    check(distance(centre, shoulder) < 1e-3, "bent: shoulder ring centre from (0, 0, 0)", distance(centre, shoulder),
          1e-3);
    require(sd_deformer_get_volumes(deformer, 1, &rest_volume, &before, &after), "sd_deformer_get_volumes");
    check(fabs(after / rest_volume - 1.0) < 1e-3, "bent: sweep volume / rest volume - 1", after / rest_volume - 1.0,
          1e-3);
    printf("(before the volume control: %.4f x the rest volume)\n", before / rest_volume);

    sd_deformer_destroy(deformer);
    sd_binding_destroy(binding);
    sd_rig_destroy(rig);
    return failures == 0 ? 0 : 1;
}
