// Vector, quaternion and matrix types of the core (GLM), and the core's error type.
//
// Rest-pose work (fitting, binding, per-frame key setup) runs in double precision; only the
// per-vertex kernel of a frame runs in float, which keeps the rest-pose round trip exact to
// float rounding.
#pragma once

#define GLM_FORCE_CTOR_INIT
#include <glm/glm.hpp>
#include <glm/gtc/quaternion.hpp>

#include <stdexcept>
#include <string>

namespace sd {

using glm::dmat3;
using glm::dmat4;
using glm::dquat;
using glm::dvec2;
using glm::dvec3;
using glm::dvec4;

/// Thrown inside the core for invalid input; the C ABI turns it into SD_ERR_INVALID_ARGUMENT.
struct InvalidInput : std::runtime_error {
    using std::runtime_error::runtime_error;
};

/// Thrown by the blob reader; the C ABI turns it into SD_ERR_CORRUPT_DATA.
struct CorruptData : std::runtime_error {
    using std::runtime_error::runtime_error;
};

/// Rotates v by a quaternion that need not be normalised: R(q/|q|) v.
inline dvec3 rotate_unnormalized(const dquat& q, const dvec3& v) {
    const dvec3 u(q.x, q.y, q.z);
    const double s = 2.0 / glm::dot(q, q);
    const dvec3 uv = glm::cross(u, v);
    return v + s * (q.w * uv + glm::cross(u, uv));
}

}  // namespace sd
