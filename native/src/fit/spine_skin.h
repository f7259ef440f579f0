// The skin beside a trunk's spine follows the spine's bones.
//
// A trunk key moves its whole section as a blend of the spine's bones under a tent about as
// wide as the body (rig/key_motion.h), which keeps the belly from folding into itself; but the
// skin of the back a few centimetres behind the spine is carried by that blend too, and a
// blend of turns about joints a vertebra apart pushes it out from its own bone (MakeHuman's
// lower back at spine_bend_45: 1.091x its rest distance from the spine with no volume kept,
// Preserve Volume 1.069). Near the spine that skin is given back to the spine's bones by its
// own skin weights, as Preserve Volume moves it, fading to the sweep further out.
#pragma once

#include "fit/chains.h"
#include "fit/regions.h"
#include "geometry/mesh.h"
#include "rig/rig.h"

#include <cstdint>
#include <vector>

namespace sd::fit {

/// Within this share of the trunk keys' median depth half-axis from the spine's bones the skin
/// follows the bones alone; beyond the second, the sweep alone (a smoothstep between).
constexpr double kSpineSkinInner = 0.45;
constexpr double kSpineSkinOuter = 0.8;

/// Moves, for every vertex on a thick chain's sweep (Sweep::bends_smoothly; `chain_sweep` the
/// sweep of each chain, -1 for none) near its links, that share of its sweep weight to those
/// bones, split by the vertex's own skin weights on them (#V*slots; a vertex with none on them
/// keeps its sweep weight). Widens the bone slots as needed. Returns the number of vertices changed.
int give_spine_skin_to_bones(const FitMesh& mesh, const Rig& rig, const ChainSet& chains,
                             const std::vector<int>& chain_sweep, int slots, const int32_t* bones, const float* weights,
                             RegionWeights& regions);

}  // namespace sd::fit
