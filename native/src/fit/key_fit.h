// Key ellipses of one chain (Sect. 3.2): one per joint, centered at the joint, and
// `keys_per_link` intermediate ones per link, centered at their section's centroid; each
// fitted to the cross-section of the mesh in its plane.
#pragma once

#include "fit/chains.h"
#include "geometry/mesh.h"
#include "fit/regions.h"
#include "rig/key_ellipse.h"
#include "rig/skeleton.h"

#include <string>
#include <vector>

namespace sd::fit {

struct KeyOptions {
    int keys_per_link = 2;
    /// Keys more on an arm's or leg's links below an interior joint (forearm, shin), so the
    /// joint's turn is taken up closer to it.
    int extra_keys_after_joint = 1;
    /// Interior joint keys of a joint bent at rest (an A-pose elbow) lie in the bisector of
    /// the two links instead of orthogonal to the lower link: the pose rule turns them by half
    /// the joint's rotation, which keeps a bisector a bisector. Straight joints: the same.
    bool bisect_bent_joints = true;
    /// Below this share of the loop (by length) owned by the chain, the cut is not used.
    double min_owned_fraction = 0.3;
    /// Scale each fitted ellipse so that π a b equals its section's area (the least-squares
    /// fit of a polygon inscribed in an ellipse is the ellipse itself, slightly larger).
    bool match_section_area = false;
};

/// How one key ellipse came about, for the report and the tests.
struct KeyReport {
    std::string role;  ///< "start", "joint", "intermediate", "end"
    int bone = -1, joint_parent = -1;
    dvec3 center{0.0}, normal{0.0}, first_axis{0.0};
    double a = 0.0, b = 0.0;
    double section_area = 0.0;    ///< area of the cross-section polygon it was fitted to (its own part)
    double ellipse_area = 0.0;    ///< π a b of the least-squares fit (before any scaling or smoothing)
    double fit_rms = 0.0;         ///< RMS radial distance of the section to the ellipse
    double owned_fraction = 0.0;  ///< share of the cut loop (by length) that belongs to the chain
    int loop_points = 0;
    bool fallback = false;  ///< no usable section: interpolated from neighbouring keys
    std::vector<std::string> notes;
};

struct ChainFit {
    std::vector<KeyEllipse> keys;
    std::vector<KeyReport> reports;
    std::vector<std::string> notes;
    std::string error;  ///< non-empty: the chain got no sweep
};

/// Places and fits the key ellipses of chain `chain_index`. Never throws for a bad cut:
/// problems become notes, fallbacks, or the error of the chain.
ChainFit fit_chain(const FitMesh& mesh, const Skeleton& skeleton, const ChainSet& chains, int chain_index,
                   const PartShares& shares, const KeyOptions& options);

}  // namespace sd::fit
