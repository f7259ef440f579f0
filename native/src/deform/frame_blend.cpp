#include "deform/frame_blend.h"

#include <glm/gtc/quaternion.hpp>

#include <cmath>

namespace sd {

BoneFrame bone_frame(const float m[3][4]) {
    BoneFrame f{};
    glm::dmat3 r;
    bool rigid = true;
    for (int c = 0; c < 3; ++c) {
        glm::dvec3 col(m[0][c], m[1][c], m[2][c]);
        const double n = glm::length(col);
        rigid = rigid && std::abs(n - 1.0) < 1e-5;
        r[c] = n > 0.0 ? col / n : glm::dvec3(c == 0, c == 1, c == 2);
    }
    rigid = rigid && std::abs(glm::dot(r[0], r[1])) < 1e-5 && std::abs(glm::dot(r[1], r[2])) < 1e-5 &&
            std::abs(glm::dot(r[0], r[2])) < 1e-5;
    const glm::dquat u = glm::normalize(glm::quat_cast(r));
    const double q[4] = {u.x, u.y, u.z, u.w}, t[3] = {m[0][3], m[1][3], m[2][3]};
    // ½ (t, 0) q
    const double d[4] = {
        0.5 * (t[0] * q[3] + t[1] * q[2] - t[2] * q[1]), 0.5 * (-t[0] * q[2] + t[1] * q[3] + t[2] * q[0]),
        0.5 * (t[0] * q[1] - t[1] * q[0] + t[2] * q[3]), -0.5 * (t[0] * q[0] + t[1] * q[1] + t[2] * q[2])};
    for (int i = 0; i < 4; ++i) {
        f.q[i] = static_cast<float>(q[i]);
        f.d[i] = static_cast<float>(d[i]);
    }
    f.rigid = rigid;
    return f;
}

}  // namespace sd
