// How each key ellipse follows the skeleton (Sect. 4.1), derived once per sweep from its keys
// and the rest skeleton (never stored: a rig blob gives the same motions when read back).
//
// The paper: a joint key keeps its center at the joint and turns by half the joint's
// rotation; an intermediate key follows its link rigidly. We keep that for the limbs, and
// depart twice:
//  - Twist is spread along the last link. The end key (wrist, ankle, head) takes the whole
//    twist of the hand, foot or head; the intermediate keys before it take a share
//    proportional to their place along the link. With rigid intermediate keys the whole
//    turn happened between the last intermediate key and the wrist, where the hand's own
//    skin weight blends in, and the skin collapsed into a ring-shaped groove.
//  - A thick chain bends smoothly. Where the ellipses are wide against their links (a torso:
//    vertebrae a few centimetres long in a body 25 cm deep), the keys follow a blend of the
//    chain's bones over a window about as wide as the body (center: the blended transforms;
//    orientation: the blended rotations). Two neighbouring planes cross on the line about
//    which they turn; folding at each joint puts that line on the spine, and the belly, more
//    than a vertebra's length times the bend in front of it, passes through itself.
#pragma once

#include "rig/key_ellipse.h"
#include "rig/skeleton.h"

#include <utility>
#include <vector>

namespace sd {

struct KeyMotion {
    /// Thick chains: (bone, weight) pairs, weights summing to 1; the key follows their blend.
    std::vector<std::pair<int, double>> blend;
    /// Otherwise rot(from) * swing^swing_share * twist^twist_share * q_rest, with swing and
    /// twist of rot(from)^-1 rot(to) about `axis` (rest space); from == to: rigid.
    int from_bone = -1, to_bone = -1;
    double swing_share = 0.0, twist_share = 0.0;
    dvec3 axis{0, 0, 1};
    /// Joint keys: the center turns with the key about this rest point (the joint), so a key
    /// centered off its joint (a spine key at its section's centroid) stays in its plane.
    bool turns_about_pivot = false;
    dvec3 pivot{0.0};
    /// The keys of a limb whose last link twists: the rest axis the key's section turns about
    /// (its link's direction; a joint key's normal), else zero; `pivot` is then the point on
    /// it. Between keys the trajectory turns with the frame's twist about each key's axis
    /// (twisted_trajectory.h) rather than cutting the chord between twisted centers.
    dvec3 twist_axis{0.0};
    /// An arm's first two keys (the shoulder and the key after it, trunk.h): the body's down at
    /// rest, else zero. As the swing lowers the arm towards it the key takes up to
    /// `lowering_share` of the swing instead of `swing_share`, as it raises the arm up to
    /// `raising_share` (shoulder_swing_share).
    dvec3 lowering{0.0};
    double lowering_share = 0.0, raising_share = 0.0;
};

/// How far (the change of the link's unit direction along the body's down) a swing must lower
/// or raise an arm before its shoulder keys take the whole of `lowering_share` or `raising_share`.
constexpr double kFullLowering = 0.5;

/// The share of the swing a joint key takes: `swing_share`, moving smoothly to
/// `lowering_share` as the swing carries the key's rest normal `axis` towards `lowering`, and to
/// `raising_share` as it carries it away. Continuous in the swing; equal to `swing_share` for a
/// key with no `lowering`.
double shoulder_swing_share(const KeyMotion& m, const dquat& swing);

/// A chain is thick when its intermediate keys' larger half-axis is at least this share of
/// their link's length (median over the keys): a torso, not an arm or a leg.
constexpr double kThickChainRatio = 0.5;

/// A thick chain's keys blend its bones under a tent this many times the keys' median larger
/// half-axis wide on either side. spine_bend_45, r_max (skin-to-bone distance ratio) with a
/// box window of one half-axis (before) and this tent: MakeHuman 13.4K 1.263 -> 1.192 and
/// 53.5K 1.28 -> 1.19 (Preserve Volume 1.07 / 1.09), the procedural 75K and 4.7K characters
/// 1.09 / 1.10 -> 1.033 / 1.042 (1.05 / 1.05), CesiumMan 1.109 -> 1.083 (1.27). Narrower
/// (a box of half a half-axis) drew a band and a kink in the back; wider lags the bones.
constexpr double kThickChainTent = 0.75;

/// The motion of every key of one sweep (see the file comment).
std::vector<KeyMotion> key_motions(const std::vector<KeyEllipse>& keys, const Skeleton& skeleton);

}  // namespace sd
