// A simple sweep rig for tests and benchmarks that do not exercise automatic fitting:
// key ellipses sit on the bones of named chains (a joint key at every joint, intermediate
// keys on every link), sized from the skin vertices around them, and sweep weights taken
// from the character's own skin weights. The real, robust fitting lives in native/src/fit.
#pragma once

#include "bind/bind.h"
#include "rig/rig.h"

#include <sweepdeform_io/character.h>

#include <string>
#include <vector>

namespace sd::testing {

/// A chain of links (bone names, from the body outwards); `start_parent` is the bone the
/// first link hangs from ("" = none: the first key just rides the first link), `end_child`
/// the bone after the last link ("" = none).
struct ChainSpec {
    std::string start_parent;
    std::vector<std::string> links;
    std::string end_child;
};

/// The arm, leg, torso and neck chains of the MakeHuman "game_engine" rig.
std::vector<ChainSpec> makehuman_chains();

struct BoneRig {
    Rig rig;
    /// Arguments of bind_vertices: 2 sweep slots, 4 bone slots per vertex.
    std::vector<int32_t> sweep_ids, bone_ids;
    std::vector<float> sweep_weights, bone_weights;
    Binding bind(const io::Character& c) const;
};

/// Builds the rig: chains resolved by name (@throws std::runtime_error naming a missing
/// bone), `intermediate_keys` per link.
BoneRig make_bone_rig(const io::Character& c, const std::vector<ChainSpec>& chains, int intermediate_keys = 2);

}  // namespace sd::testing
