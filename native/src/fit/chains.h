// Sweep chains from the skeleton (Sect. 3.2): which bones the torso, neck, arm and leg
// sweeps run along, found from the hierarchy and the rest geometry (branching, symmetry,
// bone lengths), with bone names only as a hint.
#pragma once

#include "rig/skeleton.h"

#include <string>
#include <vector>

namespace sd::fit {

enum class ChainKind { Torso, Neck, Arm, Leg, Custom };
const char* chain_kind_name(ChainKind kind);

/// One sweep chain: links from the body outwards.
struct Chain {
    ChainKind kind = ChainKind::Custom;
    int side = 0;            ///< +1 the character's left, -1 its right, 0 centre or unknown
    std::string name;        ///< "torso", "neck", "arm_l", "leg_r", "chain_3", ...
    std::vector<int> bones;  ///< links; the swept ones' skin weights go to this chain's sweep
    /// bones[first_swept] is where the sweep starts: 1 when bones[0] is a clavicle (or a
    /// hip bone) that runs inside the torso, 0 otherwise. Such an inner link's skin weight
    /// stays with the bone itself (see BoneOwners::inner).
    int first_swept = 0;
    int end_bone = -1;      ///< the bone beyond the last link (hand, foot, head, neck), or -1
    int parent_chain = -1;  ///< the chain it hangs from (limbs, neck: the torso), or -1
    int joint_parent = -1;  ///< upper link of the sweep's first joint (clavicle, pelvis), or -1
    /// Per bone, 1 where it continues the bone before it as one anatomical segment (Rigify's
    /// DEF-forearm.L.001, DAZ's twist bones, MakeHuman's lowerarm02.L); empty when none does.
    /// The sweep takes each segment as one link that rides the segment's first bone.
    std::vector<char> continues;

    /// The swept links: the first bone of each segment, from bones[first_swept] on.
    std::vector<int> links() const;
    /// The joints the sweep runs through, #links + 1: each link's head, then the end bone's head
    /// (the last bone's tail when there is none). Joint to joint, not head to tail: a glTF rig's
    /// tails are guesses, and a link cut into several bones ends where its last bone does.
    std::vector<dvec3> joints(const Skeleton& s) const;
};

/// Body axes found from the skeleton: up from the hips to the head, left from the legs,
/// forward from the feet (or the bone names when the legs have no feet).
struct BodyFrame {
    dvec3 up{0, 0, 1}, left{1, 0, 0}, forward{0, -1, 0};
    bool sides_known = false;  ///< false: "left" may be the character's right
};

struct ChainSet {
    std::vector<Chain> chains;
    BodyFrame frame;
    double size = 1.0;               ///< diagonal of the joints' bounding box (skeleton units)
    std::vector<std::string> notes;  ///< how it was decided, for the report
};

/// Finds the torso, neck, arm and leg chains of a humanoid skeleton.
///  - The hips are the first bone below the root where two or more long branches split;
///    the branch holding most extremities is the spine, the others are the legs.
///  - The spine is followed from the hips towards the head, at each bone taking the child
///    whose far end is nearest the body's mid-plane; long side branches are the arms. The
///    torso runs from the hips (and the skinned bones just above them: 3ds Max Biped's pelvis,
///    above the spine bone its thighs hang from) to the deepest spine bone an arm hangs from,
///    unless that is a neck (Biped's clavicles hang from the neck: see the .cpp).
///  - Along an arm or a leg (each step into the child reaching farthest, so a twist bone
///    hung beside a link is passed by), bones that continue one another straight are one
///    segment (a limb bone cut in two); the upper and lower link are the two consecutive
///    segments with the largest summed length; bones before them are a clavicle (or hip
///    bone), the next bone is the hand (foot). A bone with three or more children (fingers)
///    ends the search.
///  - The head is the bone after the neck with the most skin weight (or a bone named
///    "head", or the second bone after the chest).
/// @param names      #B bone names, or empty (only hints: sides, head)
/// @param bone_mass  #B summed skin weight per bone, or empty
/// @throws InvalidInput naming what is missing (no branching, no legs, ...)
ChainSet find_chains(const Skeleton& skeleton, const std::vector<std::string>& names,
                     const std::vector<double>& bone_mass);

/// Chains given explicitly (user override): bone index lists, each from the body outwards,
/// every bone a descendant of the one before. Kind Custom; the end bone is the child of the
/// last bone that continues its direction best.
/// @throws InvalidInput on an index out of range, a bone in two chains, a broken path.
ChainSet chains_from_lists(const Skeleton& skeleton, const std::vector<std::vector<int>>& lists);

/// Which chain each bone belongs to, and which chain's sweep carries its skin weights.
struct BoneOwners {
    std::vector<int> chain;     ///< #B chain index, or -1 for a rigid (bone-driven) bone
    std::vector<int> attached;  ///< #B for rigid bones the chain they hang from (hand -> arm), or -1
    /// #B: 1 for an inner link, a link before the chain's first swept one (a clavicle, a hip
    /// bone). It belongs to its chain (its skin counts as the chain's part when the keys are
    /// fitted) but the sweep starts after it, so its skin weight drives the skin with the
    /// bone itself (see weights_from_skin).
    std::vector<char> inner;
};

/// Links belong to their chain; the end bone of a chain (hand, foot, head) and everything
/// below it are rigid; any other bone (twist, breast, helper bones) goes with its parent.
BoneOwners bone_owners(const Skeleton& skeleton, const ChainSet& chains);

}  // namespace sd::fit
