// How fast a limb's twist may change along its last link on a given mesh.
//
// A forearm turns as the square of the place along it (key_motion.cpp): the muscle bellies
// at the elbow hardly move while the wrist turns. On a dense mesh that looks right; on a game
// mesh with four or five rings of vertices along the forearm the square puts 36-44 % of the
// hand's turn into the last gap between rings, whose quads then twist flat across their diagonals
// (the 2.9K MakeHuman body's forearm section 0.54 of rest at 180 degrees, Preserve Volume's
// 0.63; spread in proportion to the place, 0.77). The fitting measures the rings and lowers
// the power towards 1 until the last gap before the wrist takes at most a sixth of the twist,
// which the square keeps to from 11.5 rings on (the 13K MakeHuman male's shins and neck; its
// forearms, 10.3 rings, take 1.79).
#pragma once

#include "fit/regions.h"
#include "geometry/mesh.h"

namespace sd::fit {

/// The greatest share of the end key's twist the last gap between rings may take.
constexpr double kLastRingGapShare = 1.0 / 6.0;

/// The rings of vertices along a link: the link's length over the median length, along it, of
/// the edges that run along it (|d . axis| >= 0.7 |d|) between vertices the chain owns
/// (share >= 0.5) that lie beside the link. 0 when fewer than 8 such edges are found.
double rings_along(const FitMesh& mesh, const PartShares& shares, int chain, const dvec3& start, const dvec3& end);

/// The end key's twist spread for a link with `rings` rings (KeyEllipse::twist_spread): the
/// largest power p in [1, 2] with 1 - (1 - 1/rings)^p <= kLastRingGapShare, 1 when none is (6
/// rings or fewer: the place itself spreads it most evenly); 2 when rings is 0 (not measured).
double twist_spread_for(double rings);

}  // namespace sd::fit
