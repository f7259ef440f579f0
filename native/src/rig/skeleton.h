// The rest skeleton and one pose of it: per-bone deformation matrices P * rest^-1 and their
// rotations, which is everything the key ellipses and the bone-driven parts follow.
#pragma once

#include "math/math_types.h"

#include <vector>

namespace sd {

struct Skeleton {
    std::vector<int> parents;  ///< #B, parent index or -1; no cycles
    std::vector<dmat4> rest;   ///< #B rest matrices, armature space
    std::vector<dmat4> rest_inverse;
    std::vector<dvec3> heads, tails;

    int bone_count() const { return static_cast<int>(parents.size()); }
    /// The diagonal of the heads' and tails' bounding box: the skeleton's size.
    double extent() const;

    /// Validates and stores the arrays (see sd_rig_create). @throws InvalidInput
    static Skeleton from_arrays(int bone_count, const int* parents, const float* rest, const float* heads,
                                const float* tails);
    /// The same from double precision data (a rig blob). @throws InvalidInput
    static Skeleton build(std::vector<int> parents, std::vector<dmat4> rest, std::vector<dvec3> heads,
                          std::vector<dvec3> tails);
};

/// One pose: for every bone its deformation M_b = P_b rest_b^-1 and the rotation of M_b.
struct SkeletonPose {
    std::vector<dmat4> deform;    ///< #B
    std::vector<dquat> rotation;  ///< #B unit quaternions, polar rotation of deform's 3x3

    /// @param pose  #B*16 column-major posed bone matrices (armature space)
    /// @throws InvalidInput on a non-finite or degenerate matrix (bone index in the message)
    void set(const Skeleton& skeleton, const float* pose);
    /// The rest pose (all identities).
    void set_rest(const Skeleton& skeleton);
};

/// Reads a column-major 4x4 matrix and checks it as check_matrix does.
dmat4 read_matrix(const float* m16, const char* what, int index);
/// @throws InvalidInput unless m is finite, affine and neither degenerate nor enormous.
void check_matrix(const dmat4& m, const char* what, int index);

}  // namespace sd
