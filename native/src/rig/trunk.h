// Which sweeps leave the body's trunk sideways (the arms, at the shoulders) and which
// continue it along its axis (the legs, the neck): skin shared with the first kind is a web
// (the armpit), skin shared with the second is filled (the buttock, the base of the neck).
#pragma once

#include "rig/rig.h"

#include <vector>

namespace sd {

/// Per sweep: its first key is a joint whose normal lies more than 45 degrees off the trunk's
/// axis. The trunk is the first sweep that starts free (its first key is no joint); a rig
/// without one has no sideways sweep.
std::vector<char> sweeps_leaving_trunk_sideways(const Rig& rig);

/// The trunk's rest axis, from its first key's centre towards its last (unit), or zero where the
/// rig has no trunk (no sweep that starts free with two keys or more).
dvec3 trunk_axis(const Rig& rig);

/// Sets each arm's shoulder key (the first key of a sweep leaving the trunk sideways) to take
/// the whole swing as the arm is lowered towards the body's down (KeyMotion::lowering) and 0.6
/// of it as the arm is raised, and the key after it (on the same bone) to follow the arm's
/// whole swing as it is lowered and 0.88 of it as it is raised; clears that on every other
/// sweep. Called whenever the rig gains a sweep.
void set_shoulder_motions(Rig& rig);

}  // namespace sd
