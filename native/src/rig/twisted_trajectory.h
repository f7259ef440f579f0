// The trajectory where a sweep's sections turn about their bones (a limb whose last link
// twists: the forearm, the shin).
//
// A key of the last link twists about the link and turns about a pivot on it (key_motion.cpp),
// so its center, a centimetre or three off the bone, moves on a circle about the link. The
// paper's trajectory, the cubic through the key centers, cuts that circle's chord between keys
// twisted by different angles: the skin there came closer to the bone and then further from it
// than at rest (a tube 2 cm off its bone, hand twisted 180 degrees: 2.7 % of its distance from
// the bone; MakeHuman's forearm r_max 1.0295 where Preserve Volume's is 1.0293). Here every
// key's posed center turns, between keys, about a line through a pivot P with the twist the
// sections' frame has there relative to the key's own:
//
//   C(u) = Σ_k φ_k(u) (P + T_k(u) (c_k - P)) = C_paper(u) + Σ_k φ_k(u) (T_k(u) - 1) (c_k - P),
//
// φ_k the cubic's cardinal functions, c_k the key's posed center, T_k(u) the twist about the
// line's axis a of R(u) R_rest(u)^-1 R_k^-1. The line: in the last link's spans the link's own
// (the posed axis and pivot of the span's intermediate key), for every key's term; elsewhere
// each key's own (its link, a joint key's normal, through its pivot). Every key takes part, the
// ones that do not twist too: with the forearm's alone, the cardinal functions' negative lobes
// over the elbow's keys made it worse (2.7 % -> 7.7 %). And about the link's line in its spans:
// the upper arm's keys, turned about their own link (8.5 degrees off the forearm's in an
// A-pose), put the forearm's sections up to 0.6 mm off its turn (MakeHuman: its skin 1.013x its
// rest distance from the bone at 180 degrees, now 1.002). A bend about an axis across the
// lines has no twist about them and leaves the paper's cubic; a twist alone turns every
// section about the bone (1.8e-5).
// The correction, zero at the keys, is sampled five times a span and handed to the kernel
// with the paper's cubic as one cubic per half-span.
#pragma once

#include "rig/rig.h"

#include <array>
#include <vector>

namespace sd {

/// The trajectory above for `sweep` posed as `posed` (centers, after corrections and volume
/// shifts; rotations), as one cubic in the span's u per half-span ([span][half]); empty when no
/// key of the sweep turns about its link (KeyMotion::twist_axis): the paper's cubic is then
/// `posed`'s own.
std::vector<std::array<CubicSpan, 2>> twisted_trajectory(const Sweep& sweep, const SweepGeometry& posed);

}  // namespace sd
