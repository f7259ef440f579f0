// Muscle bulge (Sect. 4.3): "As the arm bends, the binding of skin vertices to underlying
// muscles is activated by increasing the weights influencing the muscles."
//
// A muscle is a patch of a limb's sweep: a range of the sweep parameter (along the link) and
// an angular sector around the ellipse (the flexor side: biceps on the front of the upper
// arm, the calf on the back of the shin). Its skin vertices are bound to it with static
// weights — a smooth plateau over the range and the sector whose edges fall off over the
// editable `falloff` share of their extent — and, as the joint flexes, pushed outward along
// the moving ellipse's radial direction R(t_V) (cos θ_V, sin θ_V, 0) by
//     strength * activation(flexion) * weight_V * |d_V|,
// |d_V| the vertex's rest distance from the ellipse center; activation rises smoothly from
// 0 at the rest angle to 1 at `full_flexion`. The displacement is the muscle sweep's extra
// radius, so the bulge deforms with the sweep (bending, twisting, volume control).
#pragma once

#include "anatomy/falloff.h"
#include "anatomy/skin_parts.h"
#include "rig/rig.h"
#include "rig/skeleton.h"

#include <string>
#include <vector>

namespace sd::anatomy {

struct MuscleSpec {
    std::string name;
    int joint = -1;  ///< the joint whose flexion activates it
    int sweep = -1;
    double t0 = 0, t1 = 0;      ///< rest sweep parameter range (the sweep's knot units)
    dvec3 side{0.0};            ///< rest direction of the sector's middle (unit)
    double half_width = 1.3;    ///< radians
    double full_flexion = 1.9;  ///< radians of flexion beyond the rest pose at which activation reaches 1
};

class MuscleBulge {
public:
    MuscleBulge(MuscleSpec spec, const Rig& rig, const SkinParts& parts, double falloff);
    /// Recomputes the vertex weights for a new falloff share (0.05..0.5).
    void set_falloff(const Rig& rig, const SkinParts& parts, double falloff);

    const MuscleSpec& spec() const { return spec_; }
    int vertex_count() const { return static_cast<int>(vertices_.size()); }
    static double activation(double flexion, double full_flexion);

    /// Adds the bulge for `flexion` (radians) to positions. @return the largest displacement.
    double apply(const Rig& rig, const SkeletonPose& pose, double flexion, double strength, float* positions,
                 VertexEdits& edits) const;

private:
    MuscleSpec spec_;
    double falloff_ = 0.35;
    std::vector<int32_t> vertices_, span_;
    std::vector<float> u_, weight_, dir_;  // dir_: #2 per vertex, radial direction in the ellipse frame
};

}  // namespace sd::anatomy
