#include "rig/skeleton.h"

#include <cmath>
#include <limits>

namespace sd {

void check_matrix(const dmat4& m, const char* what, int index) {
    const auto fail = [&](const std::string& why) {
        throw InvalidInput(std::string(what) + " of bone " + std::to_string(index) + " " + why);
    };
    for (int c = 0; c < 4; ++c)
        for (int r = 0; r < 4; ++r)
            if (!std::isfinite(m[c][r]) || std::abs(m[c][r]) > 1e12) fail("has a non-finite or enormous value");
    const double scale = std::abs(glm::determinant(dmat3(m)));
    if (!(scale > 1e-12) || !(scale < 1e12)) fail("is degenerate (3x3 determinant " + std::to_string(scale) + ")");
    if (std::abs(m[0][3]) + std::abs(m[1][3]) + std::abs(m[2][3]) > 1e-6 || std::abs(m[3][3] - 1.0) > 1e-6)
        fail("is not affine (bottom row must be 0 0 0 1)");
}

dmat4 read_matrix(const float* m, const char* what, int index) {
    dmat4 out;
    for (int c = 0; c < 4; ++c)
        for (int r = 0; r < 4; ++r) out[c][r] = m[c * 4 + r];
    check_matrix(out, what, index);
    return out;
}

Skeleton Skeleton::from_arrays(int count, const int* parents, const float* rest, const float* heads,
                               const float* tails) {
    if (count < 1 || count > 100000)
        throw InvalidInput("bone count must be in 1..100000, got " + std::to_string(count));
    if (!parents || !rest || !heads || !tails) throw InvalidInput("a skeleton array is NULL");
    std::vector<dmat4> r(count);
    std::vector<dvec3> h(count), t(count);
    for (int b = 0; b < count; ++b) {
        for (int i = 0; i < 16; ++i) r[b][i / 4][i % 4] = rest[16 * b + i];
        h[b] = dvec3(heads[3 * b], heads[3 * b + 1], heads[3 * b + 2]);
        t[b] = dvec3(tails[3 * b], tails[3 * b + 1], tails[3 * b + 2]);
    }
    return build(std::vector<int>(parents, parents + count), std::move(r), std::move(h), std::move(t));
}

double Skeleton::extent() const {
    dvec3 lo(std::numeric_limits<double>::infinity()), hi = -lo;
    for (int b = 0; b < bone_count(); ++b) {
        lo = glm::min(lo, glm::min(heads[b], tails[b]));
        hi = glm::max(hi, glm::max(heads[b], tails[b]));
    }
    return glm::length(hi - lo);
}

Skeleton Skeleton::build(std::vector<int> parents, std::vector<dmat4> rest, std::vector<dvec3> heads,
                         std::vector<dvec3> tails) {
    const int count = static_cast<int>(parents.size());
    if (count < 1 || count > 100000)
        throw InvalidInput("bone count must be in 1..100000, got " + std::to_string(count));
    if (rest.size() != parents.size() || heads.size() != parents.size() || tails.size() != parents.size())
        throw InvalidInput("skeleton arrays differ in length");
    Skeleton s;
    for (int b = 0; b < count; ++b) {
        if (parents[b] < -1 || parents[b] >= count || parents[b] == b)
            throw InvalidInput("bone " + std::to_string(b) + " has parent " + std::to_string(parents[b]) +
                               ", not a bone index or -1");
        check_matrix(rest[b], "rest matrix", b);
        for (const dvec3& p : {heads[b], tails[b]})
            if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z) || !(glm::length(p) < 1e12))
                throw InvalidInput("head or tail of bone " + std::to_string(b) + " is not finite");
        if (!(glm::length(tails[b] - heads[b]) > 0.0))
            throw InvalidInput("bone " + std::to_string(b) + " has zero length");
        s.rest_inverse.push_back(glm::inverse(rest[b]));
    }
    // The hierarchy must be a forest: walking up from any bone reaches a root.
    for (int b = 0; b < count; ++b) {
        int steps = 0;
        for (int p = parents[b]; p != -1; p = parents[p])
            if (++steps > count) throw InvalidInput("bone " + std::to_string(b) + " is in a parent cycle");
    }
    s.parents = std::move(parents);
    s.rest = std::move(rest);
    s.heads = std::move(heads);
    s.tails = std::move(tails);
    return s;
}

/// Rotation of a matrix that may carry scale: normalise the columns, then re-orthogonalise
/// through the quaternion (exact for rotation times uniform or axis-aligned scale).
static dquat rotation_of(const dmat4& m) {
    dmat3 r(m);
    for (int c = 0; c < 3; ++c) r[c] = glm::normalize(r[c]);
    if (glm::determinant(r) < 0.0) r[2] = -r[2];  // a mirror: keep a proper rotation
    return glm::normalize(glm::quat_cast(r));
}

void SkeletonPose::set(const Skeleton& skeleton, const float* pose) {
    const int n = skeleton.bone_count();
    deform.resize(n);
    rotation.resize(n);
    for (int b = 0; b < n; ++b) {
        deform[b] = read_matrix(pose + 16 * b, "pose matrix", b) * skeleton.rest_inverse[b];
        rotation[b] = rotation_of(deform[b]);
    }
}

void SkeletonPose::set_rest(const Skeleton& skeleton) {
    deform.assign(skeleton.bone_count(), dmat4(1.0));
    rotation.assign(skeleton.bone_count(), dquat(1, 0, 0, 0));
}

}  // namespace sd
