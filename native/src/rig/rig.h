// A rig: the rest skeleton and the sweeps of key ellipses that control the skin, with the
// artist's pose-space corrections of the key ellipses (Sect. 4.2).
#pragma once

#include "rig/key_correction.h"
#include "rig/key_ellipse.h"
#include "rig/key_motion.h"
#include "rig/skeleton.h"
#include "rig/volume.h"

#include <vector>

namespace sd {

/// At most this many corrections per key ellipse.
constexpr int kMaxCorrectionsPerKey = 64;

/// The joint whose angle a key's corrections are keyed by:
///  - a joint key: its own joint (joint_parent = upper link, bone = lower link);
///  - an intermediate key: the joint key of its sweep nearest along the rest curve (chord
///    length; a tie goes to the one nearer the body);
///  - a sweep without joint keys: the key's bone and the bone's parent in the skeleton;
///    a root bone has no joint (parent -1, the angle is always 0).
/// The angle is the one between the directions (tail - head) of the two links, turned by
/// each link's rotation in the pose: 0 for a straight limb, pi for one folded back.
struct KeyJoint {
    int parent = -1, child = -1;                      ///< upper and lower link (bone indices)
    dvec3 parent_axis{0, 0, 1}, child_axis{0, 0, 1};  ///< unit rest directions of the links
    double rest_angle = 0.0;                          ///< the angle at rest
};

/// One sweep with the rest-pose data derived from its key ellipses.
struct Sweep {
    std::vector<KeyEllipse> keys;
    SweepGeometry rest_geometry;
    HalfAxisFunctions rest_half_axes;  ///< a(t), b(t) on the rest knots
    VolumeQuadrature quadrature;
    VolumeControlKeys control_keys;
    double rest_volume = 0.0;
    std::vector<KeyJoint> joints;    ///< #K, the joint of each key (see KeyJoint)
    std::vector<KeyMotion> motions;  ///< #K, how each key follows the skeleton (key_motion.h)
    bool bends_smoothly = false;     ///< a thick chain: some key follows a blend of bones
    /// The volume control's V0: the rest volume of the sweep with the corrections at the
    /// rest angles applied to the key centers and orientations (half-axes uncorrected); equal
    /// to rest_volume unless a correction sits at a rest angle.
    double corrected_rest_volume = 0.0;
    bool has_corrections = false;  ///< any key has a (possibly muted) correction

    int key_count() const { return static_cast<int>(keys.size()); }
    int span_count() const { return key_count() - 1; }
};

/// One correction with its address, for whole-rig lists.
struct CorrectionRecord {
    int sweep = -1, key = -1;
    KeyCorrection correction;
};

struct Rig {
    Skeleton skeleton;
    std::vector<Sweep> sweeps;

    /// Validates the keys against the skeleton, derives the rest data, appends the sweep.
    /// @return the new sweep's index. @throws InvalidInput naming the offending key.
    int add_sweep(std::vector<KeyEllipse> keys);

    /// Replaces every correction of the rig (all or nothing). @throws InvalidInput
    void set_corrections(const std::vector<CorrectionRecord>& records);
    /// Replaces the corrections of one key (all or nothing). @throws InvalidInput
    void set_key_corrections(int sweep, int key, std::vector<KeyCorrection> corrections);
    /// Every correction, by sweep, key, then angle.
    std::vector<CorrectionRecord> corrections() const;
};

/// Builds a sweep's rest data from its keys (used by add_sweep and when loading a blob).
/// Corrections the keys carry are validated and kept.
Sweep make_sweep(std::vector<KeyEllipse> keys, const Skeleton& skeleton);

/// Validates `per_key` (#K lists) for the sweep and installs them, sorted by angle, with the
/// corrected rest volume. All or nothing. @throws InvalidInput naming the key
void set_sweep_corrections(Sweep& sweep, std::vector<std::vector<KeyCorrection>> per_key);

}  // namespace sd
