// Private glm helpers: conversions between flat column-major float arrays and glm doubles.
#pragma once

#include <cstddef>

#include <glm/glm.hpp>
#include <glm/gtc/quaternion.hpp>

namespace sd::io::detail {

inline glm::dmat4 load_mat4(const float* m) {
  glm::dmat4 r;
  for (int c = 0; c < 4; ++c)
    for (int k = 0; k < 4; ++k) r[c][k] = m[4 * c + k];
  return r;
}

inline void store_mat4(const glm::dmat4& m, float* out) {
  for (int c = 0; c < 4; ++c)
    for (int k = 0; k < 4; ++k) out[4 * c + k] = static_cast<float>(m[c][k]);
}

/// Quaternion from x, y, z, w (glTF order).
inline glm::dquat load_quat(const float* q) {
  return glm::dquat(q[3], q[0], q[1], q[2]);  // glm's constructor takes w first
}

/// T * R * S, the glTF local node matrix.
inline glm::dmat4 trs_matrix(const glm::dvec3& t, const glm::dquat& r, const glm::dvec3& s) {
  glm::dmat4 m(glm::mat3_cast(glm::normalize(r)));
  m[0] *= s.x;
  m[1] *= s.y;
  m[2] *= s.z;
  m[3] = glm::dvec4(t, 1.0);
  return m;
}

/// glTF Y-up -> Blender Z-up: (x, y, z) -> (x, -z, y), a +90 degree rotation about X.
inline glm::dmat4 gltf_to_blender_axes() {
  glm::dmat4 a(0.0);
  a[0][0] = 1.0;   // x -> x
  a[1][2] = 1.0;   // y -> z
  a[2][1] = -1.0;  // z -> -y
  a[3][3] = 1.0;
  return a;
}

}  // namespace sd::io::detail
