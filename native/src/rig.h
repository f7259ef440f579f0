// A rig: the rest skeleton and the sweeps of key ellipses that control the skin.
#pragma once

#include "key_ellipse.h"
#include "skeleton.h"
#include "volume.h"

#include <vector>

namespace sd {

/// One sweep with the rest-pose data derived from its key ellipses.
struct Sweep {
    std::vector<KeyEllipse> keys;
    SweepGeometry rest_geometry;
    HalfAxisFunctions rest_half_axes;  ///< a(t), b(t) on the rest knots
    VolumeQuadrature quadrature;
    VolumeControlKeys control_keys;
    double rest_volume = 0.0;

    int key_count() const { return static_cast<int>(keys.size()); }
    int span_count() const { return key_count() - 1; }
};

struct Rig {
    Skeleton skeleton;
    std::vector<Sweep> sweeps;

    /// Validates the keys against the skeleton, derives the rest data, appends the sweep.
    /// @return the new sweep's index. @throws InvalidInput naming the offending key.
    int add_sweep(std::vector<KeyEllipse> keys);
};

/// Builds a sweep's rest data from its keys (used by add_sweep and when loading a blob).
Sweep make_sweep(std::vector<KeyEllipse> keys, const Skeleton& skeleton);

}  // namespace sd
