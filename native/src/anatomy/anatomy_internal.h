// Helpers shared by the anatomy object's translation units (anatomy.cpp, anatomy_joints.cpp,
// volume_restoration.cpp). Internal.
#pragma once

#include "anatomy/anatomy.h"
#include "math/math_types.h"

#include <cstddef>

namespace sd::anatomy {

inline bool any_effect(const JointSettings& s) { return s.folding || s.protrusion || s.bulge; }

inline dvec3 point(const float* p, int v) {
    return dvec3(p[3 * static_cast<size_t>(v)], p[3 * static_cast<size_t>(v) + 1], p[3 * static_cast<size_t>(v) + 2]);
}

}  // namespace sd::anatomy
