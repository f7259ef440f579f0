// Posing the skeleton of a Character.
#pragma once

#include <vector>

#include "sweepdeform_io/character.h"

namespace sd::io {

/// Posed bone matrices at time `time_s` (seconds) of animation `animation`
/// (index into c.animations; -1 = no animation, i.e. the file's node rest pose).
///
/// Returns #B*16 floats: the column-major global matrix of each bone in scene space, in the
/// same space and bone frame as c.bone_rest (Blender's pose_bone.matrix in armature space).
/// Linear-blend-skinning matrices are pose[b] * inverse(c.bone_rest[b]).
///
/// Every node of c.nodes is evaluated: animated properties from the channels (LINEAR with
/// quaternion slerp, STEP, CUBICSPLINE Hermite), the others keep their rest local values.
/// Times outside the keys are clamped to the first/last key.
/// Throws std::out_of_range for an invalid animation index, std::invalid_argument when
/// c.nodes does not cover the bones (a hand-built Character without node tree).
std::vector<float> sample_pose(const Character& c, int animation, double time_s);

/// The rest (bind) bone matrices, #B*16: a copy of c.bone_rest.
std::vector<float> rest_pose(const Character& c);

}  // namespace sd::io
