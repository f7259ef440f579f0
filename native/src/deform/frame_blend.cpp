#include "deform/frame_blend.h"

#include <glm/gtc/quaternion.hpp>

namespace sd {

void bone_rotation(const float m[3][4], float* q) {
    glm::dmat3 r;
    for (int c = 0; c < 3; ++c) {
        glm::dvec3 col(m[0][c], m[1][c], m[2][c]);
        const double n = glm::length(col);
        r[c] = n > 0.0 ? col / n : glm::dvec3(c == 0, c == 1, c == 2);
    }
    const glm::dquat u = glm::normalize(glm::quat_cast(r));
    q[0] = static_cast<float>(u.x);
    q[1] = static_cast<float>(u.y);
    q[2] = static_cast<float>(u.z);
    q[3] = static_cast<float>(u.w);
}

}  // namespace sd
