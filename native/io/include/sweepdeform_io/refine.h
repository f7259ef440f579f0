// Catmull-Clark refinement of a Character's mesh (OpenSubdiv Far).
#pragma once

#include "sweepdeform_io/character.h"

namespace sd::io {

/// Refines c's triangle mesh `levels` times uniformly with Catmull-Clark (smooth boundaries,
/// OpenSubdiv's default Catmark rule on triangles) and returns the refined character.
///
/// * positions: refined (not projected to the limit surface). One level on a closed mesh
///   gives V + E + T vertices (13,380 -> 80,270 for the MakeHuman body).
/// * triangles: each refined quad split into 2 triangles along its shorter diagonal,
///   keeping the orientation.
/// * skin: the weights of every bone are interpolated by the same rules as the positions,
///   then the 4 largest kept and renormalised.
/// * skeleton, nodes and animations are copied unchanged.
/// levels = 0 returns a copy. Throws std::invalid_argument for levels < 0 or an invalid c.
Character refine_catmull_clark(const Character& c, int levels);

}  // namespace sd::io
